#!/usr/bin/python3
"""Faults while writing (docs/robustness.md): whatever kills or starves `vdbscatter bake`
and `render`, the output path holds either the previous file, byte for byte (or nothing,
when there was none), or a complete new one; never a partial file.

- SIGKILL at the test-only fault points (VDBSCATTER_FAULT=before-write|mid-write|
  before-rename) of the VDB, NanoVDB and image writers, and at seeded random moments over
  a measured bake (some counted from when the temporary file appears);
- stale temporary files (.NAME.tmp.PID) of dead processes are removed by the next write to
  the same path, a live process's are not, and no other name is touched;
- a full disk (a small tmpfs, when root may mount one: ENOSPC; and RLIMIT_FSIZE with
  SIGXFSZ ignored: EFBIG) gives one line and exit 1, for a fresh path and over a previous
  file, and no temporary file;
- two bakes to one path at once leave one complete bake (either one's);
- as uid 65534 (when run as root): an unreadable input folder and a read-only output folder
  get one line and exit 2; an input deleted during the bake either bakes or fails with one
  line, and no output.
Every oracle is the output's bytes or the fingerprint of a complete reference bake. Set
VDBSCATTER_FAULTS_VERBOSE=1 to print the random kills' outcomes."""
import json
import os
import random
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import pyopenvdb as vdb

EXE = os.environ["VDBSCATTER"]
# The new bake and the previous one differ in their light, so their fingerprints differ.
BAKE = ["--method", "single", "--backend", "cpu", "--sun", "0,-1,0", "-q"]
PREVIOUS = ["--method", "single", "--backend", "cpu", "--sun", "1,0,0", "-q"]
RENDER = ["--backend", "cpu", "--sun", "0,-1,0", "--size", "160x120", "-q"]
POINTS = ("before-write", "mid-write", "before-rename")
VERBOSE = os.environ.get("VDBSCATTER_FAULTS_VERBOSE") == "1"
NOBODY = 65534


def run(*args, check=0, preexec_fn=None):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=600,
                       preexec_fn=preexec_fn)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


def with_fault(point):
    return dict(os.environ, VDBSCATTER_FAULT=point)


def run_to_fault(point, *args):
    """Runs `vdbscatter ARGS` with the fault point set; returns (process, stderr): the
    process for its exit status and PID (which names its temporary files)."""
    p = subprocess.Popen([EXE, *map(str, args)], stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True, env=with_fault(point))
    _, err = p.communicate(timeout=600)
    return p, err


def temp_files(folder):
    return sorted(n for n in os.listdir(folder) if ".tmp." in n)


def read(path):
    with open(path, "rb") as f:
        return f.read()


def write(path, data):
    with open(path, "wb") as f:
        f.write(data)


def full_disk(limit):
    """preexec_fn: files larger than limit bytes cannot be written (EFBIG, not a signal)."""
    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def as_nobody():
    os.setgroups([])
    os.setgid(NOBODY)
    os.setuid(NOBODY)


def dead_pid():
    """A PID no process has: one past the kernel's largest."""
    with open("/proc/sys/kernel/pid_max") as f:
        return int(f.read()) + 1


class FaultsCliTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        root = os.environ.get("VDBSCATTER_TMP") or tempfile.gettempdir()
        os.makedirs(root, exist_ok=True)
        cls.tmp = tempfile.mkdtemp(prefix="faults_", dir=root)
        cls.volume = os.path.join(cls.tmp, "sphere.vdb")
        run("sample", "sphere", "--res", 56, "-o", cls.volume)
        # References: the new bake's fingerprint (which a complete new file must match), and
        # the previous outputs' bytes.
        cls.new = {}
        cls.previous = {}
        for ext in (".vdb", ".nvdb"):
            ref = os.path.join(cls.tmp, "reference" + ext)
            run("bake", cls.volume, "-o", ref, *BAKE)
            cls.new[ext] = cls.fingerprint(ref)
            prev = os.path.join(cls.tmp, "previous" + ext)
            run("bake", cls.volume, "-o", prev, *PREVIOUS)
            cls.previous[ext] = read(prev)
            assert cls.fingerprint(prev) != cls.new[ext]
        cls.previous[".nvdb.json"] = read(os.path.join(cls.tmp, "previous.nvdb.json"))
        cls.size = os.path.getsize(os.path.join(cls.tmp, "reference.vdb"))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    @staticmethod
    def fingerprint(path):
        """What identifies a bake: for a .vdb, each grid's name, active voxels and the sum of
        its values, and the file metadata; for a .nvdb, its bytes (NanoVDB output is
        reproducible) and its sidecar's metadata. Timings are left out. None when the file
        does not read back whole."""
        def untimed(meta):
            out = []
            for k, v in meta.items():
                # the determinants hash holds the input's path and time, which these tests
                # change (docs/sequences.md)
                if k.endswith("_seconds") or k == "vdbscatter_hash":
                    continue
                if k == "vdbscatter_scene":
                    # It names the input file, which these tests copy, move and delete.
                    scene = json.loads(v) if isinstance(v, str) else dict(v)
                    scene.get("volume", {}).pop("file", None)
                    v = json.dumps(scene, sort_keys=True)
                out.append((k, str(v)))
            return sorted(out)
        try:
            if path.endswith(".nvdb"):
                with open(path + ".json") as f:
                    return read(path), untimed(json.load(f))
            grids, meta = vdb.readAll(path)
        except (OSError, ValueError, RuntimeError, KeyError):
            return None
        prints = []
        for g in grids:
            total = 0.0
            for item in g.citerOnValues():
                total += sum(item.value) if isinstance(item.value, tuple) else item.value
            prints.append((g.name, g.activeVoxelCount(), total))
        return sorted(prints), untimed(meta)

    def folder(self, name):
        path = os.path.join(self.tmp, name)
        os.makedirs(path, exist_ok=True)
        return path

    def assert_old_or_new(self, out, ext=".vdb", fresh=False):
        """out is the previous file byte for byte (absent when fresh) or a complete new bake;
        returns which."""
        if not os.path.exists(out):
            self.assertTrue(fresh, f"{out} vanished")
            return "absent"
        if not fresh and read(out) == self.previous[ext]:
            return "previous"
        self.assertEqual(self.fingerprint(out), self.new[ext], f"{out}: neither old nor new")
        return "new"

    def assert_one_line(self, err, *parts):
        lines = err.strip().splitlines()
        self.assertEqual(len(lines), 1, err)
        for part in parts:
            self.assertIn(part, lines[0])

    def test_sigkill_at_fault_points(self):
        for ext, fresh in ((".vdb", True), (".vdb", False), (".nvdb", False)):
            with self.subTest(ext=ext, fresh=fresh):
                folder = self.folder(f"points_{ext[1:]}_{'fresh' if fresh else 'over'}")
                out = os.path.join(folder, "out" + ext)
                if not fresh:
                    write(out, self.previous[ext])
                    if ext == ".nvdb":
                        write(out + ".json", self.previous[".nvdb.json"])
                for point in POINTS:
                    p, err = run_to_fault(point, "bake", self.volume, "-o", out, *BAKE)
                    self.assertEqual(p.returncode, -signal.SIGKILL, err)
                    self.assertEqual(self.assert_old_or_new(out, ext, fresh),
                                     "absent" if fresh else "previous", point)
                    if ext == ".nvdb":
                        self.assertEqual(read(out + ".json"), self.previous[".nvdb.json"])
                    # What the killed process left: nothing before the write, its cut
                    # temporary file mid-write (the .nvdb's sidecar is written first), its
                    # whole temporary files before the rename; and each run removed the
                    # previous dead one's before writing.
                    new = temp_files(folder)
                    if point == "before-write":
                        self.assertEqual(new, [])
                    elif ext == ".vdb":
                        self.assertEqual(new, [f".out.vdb.tmp.{p.pid}"])
                        size = os.path.getsize(os.path.join(folder, new[0]))
                        self.assertEqual(size, self.size // 2 if point == "mid-write"
                                         else self.size)
                    elif point == "mid-write":
                        self.assertEqual(new, [f".out.nvdb.json.tmp.{p.pid}"])
                    else:
                        self.assertEqual(new, [f".out.nvdb.json.tmp.{p.pid}",
                                               f".out.nvdb.tmp.{p.pid}"])
                # The next bake replaces the output and removes what the dead ones left.
                run("bake", self.volume, "-o", out, *BAKE)
                self.assertEqual(temp_files(folder), [])
                self.assertEqual(self.assert_old_or_new(out, ext, True), "new")

    def test_sigkill_at_fault_points_render(self):
        """The image writer has the same points (PNG; EXR and HDR share its code)."""
        folder = self.folder("points_render")
        out = os.path.join(folder, "picture.png")
        run("render", self.volume, "-o", out, *RENDER)
        fresh = read(out)
        previous = b"previous picture"
        write(out, previous)
        for point in POINTS:
            p, err = run_to_fault(point, "render", self.volume, "-o", out, *RENDER)
            self.assertEqual(p.returncode, -signal.SIGKILL, err)
            self.assertEqual(read(out), previous, point)
            self.assertEqual(temp_files(folder),
                             [] if point == "before-write" else [f".picture.png.tmp.{p.pid}"])
        run("render", self.volume, "-o", out, *RENDER)
        self.assertEqual(temp_files(folder), [])
        self.assertEqual(read(out), fresh)

    def test_sigkill_at_random_moments(self):
        folder = self.folder("random")
        out = os.path.join(folder, "out.vdb")
        args = [EXE, "bake", self.volume, "-o", out, *BAKE]
        start = time.monotonic()
        subprocess.run(args, check=True)
        duration = time.monotonic() - start
        rng = random.Random(27)
        # 6 kills counted from the start, over 1.1x a bake; 3 from when the process's
        # temporary file appears (the write stage), over a tenth of a bake.
        kills = [(rng.uniform(0, 1.1 * duration), False) for _ in range(6)]
        kills += [(rng.uniform(0, 0.1 * duration), True) for _ in range(3)]
        outcomes, killed = [], set()
        for delay, in_write in kills:
            write(out, self.previous[".vdb"])
            p = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
            begin = time.monotonic()
            if in_write:
                own = os.path.join(folder, f".out.vdb.tmp.{p.pid}")
                while p.poll() is None and not os.path.exists(own):
                    time.sleep(0.0005)
                begin = time.monotonic()
            time.sleep(max(0.0, begin + delay - time.monotonic()))
            p.kill()
            _, err = p.communicate(timeout=600)
            killed.add(f".out.vdb.tmp.{p.pid}")
            with self.subTest(delay=delay, in_write=in_write):
                what = self.assert_old_or_new(out)
                if p.returncode == 0:
                    self.assertEqual(what, "new")
                else:
                    self.assertEqual(p.returncode, -signal.SIGKILL, err)
                # Anything left behind is a killed process's own temporary file.
                self.assertLessEqual(set(temp_files(folder)), killed)
                outcomes.append((delay, in_write, p.returncode, what, temp_files(folder)))
        subprocess.run(args, check=True)
        self.assertEqual(temp_files(folder), [])
        self.assertEqual(self.assert_old_or_new(out), "new")
        if VERBOSE:
            print(f"\nbake {duration:.2f} s", file=sys.stderr)
            for delay, in_write, status, what, left in outcomes:
                print(f"  SIGKILL {delay:.3f} s after {'the temp file' if in_write else 'start'}"
                      f": exit {status}, output {what}, left {left}", file=sys.stderr)

    def test_stale_temporaries(self):
        folder = self.folder("stale")
        out = os.path.join(folder, "out.vdb")
        dead, live = dead_pid(), os.getpid()
        # A real killed bake's file, a dead PID's, a live process's, and names that are not
        # this output's temporaries (another output's, not hidden, not a PID).
        p, err = run_to_fault("mid-write", "bake", self.volume, "-o", out, *BAKE)
        self.assertEqual(p.returncode, -signal.SIGKILL, err)
        self.assertEqual(temp_files(folder), [f".out.vdb.tmp.{p.pid}"])
        stale = [f".out.vdb.tmp.{dead}"]
        keep = [f".out.vdb.tmp.{live}", f".other.vdb.tmp.{dead}", f"out.vdb.tmp.{dead}",
                ".out.vdb.tmp.x1", f".out.vdb.tmp.{dead}.bak", f".xout.vdb.tmp.{dead}"]
        for name in stale + keep:
            write(os.path.join(folder, name), b"x")
        run("bake", self.volume, "-o", out, *BAKE)
        # The killed bake's file and the dead PID's are gone; the rest stay.
        self.assertEqual(sorted(os.listdir(folder)), sorted(keep + ["out.vdb"]))
        self.assertEqual(self.assert_old_or_new(out, fresh=True), "new")
        # A render to a picture path does the same for its own name only.
        pic = os.path.join(folder, "p.png")
        write(os.path.join(folder, f".p.png.tmp.{dead}"), b"x")
        run("render", self.volume, "-o", pic, *RENDER)
        self.assertEqual(sorted(os.listdir(folder)), sorted(keep + ["out.vdb", "p.png"]))

    def check_starved_bake(self, folder, ext, fresh, preexec_fn=None):
        """A bake into folder that runs out of room: one line and exit 1, no temporary
        file, and the folder as it was (empty, or the previous file byte for byte)."""
        out = os.path.join(folder, "out" + ext)
        if not fresh:
            write(out, self.previous[ext])
            if ext == ".nvdb":
                write(out + ".json", self.previous[".nvdb.json"])
        p = run("bake", self.volume, "-o", out, *BAKE, check=None, preexec_fn=preexec_fn)
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assert_one_line(p.stderr, f"vdbscatter bake: {out}: writing")
        self.assertEqual(temp_files(folder), [])
        if fresh:
            self.assertEqual(os.listdir(folder), [])
        else:
            self.assertEqual(read(out), self.previous[ext])
            if ext == ".nvdb":
                self.assertEqual(read(out + ".json"), self.previous[".nvdb.json"])
        return p.stderr

    def test_file_size_limit(self):
        """RLIMIT_FSIZE with SIGXFSZ ignored: every write past the limit fails (EFBIG)."""
        for ext in (".vdb", ".nvdb"):
            for fresh in (True, False):
                with self.subTest(ext=ext, fresh=fresh):
                    folder = self.folder(f"limit_{ext[1:]}_{'fresh' if fresh else 'over'}")
                    err = self.check_starved_bake(folder, ext, fresh, full_disk(self.size // 4))
                    if ext == ".vdb":
                        self.assertIn("File too large", err)
        folder = self.folder("limit_render")
        out = os.path.join(folder, "picture.exr")
        p = run("render", self.volume, "-o", out, *RENDER, check=None,
                preexec_fn=full_disk(4096))
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assert_one_line(p.stderr, f"vdbscatter render: {out}: writing OpenEXR failed")
        self.assertEqual(os.listdir(folder), [])

    def test_disk_full(self):
        """A real full disk (ENOSPC): a tmpfs with room for the previous file and a quarter
        of the new one. Needs root and mount(8)."""
        if os.geteuid() != 0:
            self.skipTest("needs root to mount a small tmpfs")
        mnt = tempfile.mkdtemp(prefix="vdbscatter_full_")
        self.addCleanup(os.rmdir, mnt)
        for ext in (".vdb", ".nvdb"):
            for fresh in (True, False):
                room = self.size // 4
                if not fresh:
                    room += len(self.previous[ext])
                    if ext == ".nvdb":
                        room += len(self.previous[".nvdb.json"])
                m = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={room}", "tmpfs", mnt],
                                   capture_output=True, text=True)
                if m.returncode != 0:
                    self.skipTest(f"cannot mount a tmpfs here: {m.stderr.strip()}")
                try:
                    with self.subTest(ext=ext, fresh=fresh):
                        err = self.check_starved_bake(mnt, ext, fresh)
                        if ext == ".vdb":
                            self.assertIn("No space left on device", err)
                finally:
                    subprocess.run(["umount", mnt], check=True)

    def test_two_bakes_at_once(self):
        other = ["--method", "single", "--backend", "cpu", "--sun", "0,0,1", "-q"]
        for ext in (".vdb", ".nvdb"):
            folder = self.folder("twice_" + ext[1:])
            ref = os.path.join(folder, "other" + ext)
            run("bake", self.volume, "-o", ref, *other)
            bakes = [self.fingerprint(ref), self.new[ext]]
            self.assertNotEqual(bakes[0], bakes[1])
            os.unlink(ref)
            if ext == ".nvdb":
                os.unlink(ref + ".json")
            out = os.path.join(folder, "out" + ext)
            # NanoVDB's two renames could interleave (one run in about twenty, before the
            # folder lock): more rounds.
            for round_ in range(2 if ext == ".vdb" else 4):
                with self.subTest(ext=ext, round=round_):
                    procs = [subprocess.Popen([EXE, "bake", self.volume, "-o", out, *a],
                                              stderr=subprocess.PIPE, text=True)
                             for a in (BAKE, other)]
                    for p in procs:
                        _, err = p.communicate(timeout=600)
                        self.assertEqual(p.returncode, 0, err)
                    self.assertEqual(temp_files(folder), [])
                    # One bake's file whole (and for NanoVDB, the sidecar of the same bake).
                    self.assertIn(self.fingerprint(out), bakes)

    def test_input_deleted_during_bake(self):
        """Deleted at once (the bake fails with one line, or had already read it), at a seeded
        random moment, and once the write has begun (the input was read: it bakes)."""
        folder = self.folder("deleted")
        out = os.path.join(folder, "out.vdb")
        volume = os.path.join(folder, "in.vdb")
        for when in (0.0, random.Random(2027).uniform(0, 0.5), "write"):
            shutil.copyfile(self.volume, volume)
            p = subprocess.Popen([EXE, "bake", volume, "-o", out, *BAKE],
                                 stderr=subprocess.PIPE, text=True)
            if when == "write":
                own = os.path.join(folder, f".out.vdb.tmp.{p.pid}")
                while p.poll() is None and not os.path.exists(own):
                    time.sleep(0.0005)
            else:
                time.sleep(when)
            os.unlink(volume)
            _, err = p.communicate(timeout=600)
            if VERBOSE:
                print(f"\ninput deleted at {when}: exit {p.returncode} {err.strip()}",
                      file=sys.stderr)
            with self.subTest(when=when):
                self.assertEqual(temp_files(folder), [])
                if when == "write":
                    self.assertEqual(p.returncode, 0, err)
                if p.returncode == 0:
                    self.assertEqual(self.assert_old_or_new(out, fresh=True), "new")
                    os.unlink(out)
                else:
                    self.assertEqual(p.returncode, 2, err)
                    self.assert_one_line(err, f"vdbscatter bake: {volume}: ")
                    self.assertEqual(os.listdir(folder), [])

    def test_unprivileged(self):
        if os.geteuid() != 0:
            self.skipTest("needs root to run the bakes as uid 65534")
        probe = subprocess.run([EXE, "--help"], capture_output=True, preexec_fn=as_nobody)
        if probe.returncode != 0:
            self.skipTest(f"{EXE} cannot be run by uid 65534 (a folder on its path is closed)")
        # The source volume may sit in a folder uid 65534 cannot read: use copies in /tmp.
        base = tempfile.mkdtemp(prefix="vdbscatter_faults_")
        self.addCleanup(shutil.rmtree, base, True)
        os.chmod(base, 0o755)
        closed = os.path.join(base, "closed")
        os.mkdir(closed, 0o700)
        shutil.copyfile(self.volume, os.path.join(closed, "in.vdb"))
        open_in = os.path.join(base, "in.vdb")
        shutil.copyfile(self.volume, open_in)
        os.chmod(open_in, 0o644)
        readonly = os.path.join(base, "readonly")
        os.mkdir(readonly, 0o755)
        shared = os.path.join(base, "shared")
        os.mkdir(shared)
        os.chmod(shared, 0o777)

        # An input in a folder nobody may enter.
        src = os.path.join(closed, "in.vdb")
        out = os.path.join(shared, "out.vdb")
        p = run("bake", src, "-o", out, *BAKE, check=None, preexec_fn=as_nobody)
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assert_one_line(p.stderr, "vdbscatter bake: ", src, "Permission denied")
        self.assertEqual(os.listdir(shared), [])
        # An input file nobody may read, in an open folder.
        private = os.path.join(base, "private.vdb")
        shutil.copyfile(self.volume, private)
        os.chmod(private, 0o600)
        p = run("bake", private, "-o", out, *BAKE, check=None, preexec_fn=as_nobody)
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assert_one_line(p.stderr, "vdbscatter bake: ", private, "Permission denied")
        self.assertEqual(os.listdir(shared), [])
        # An output folder nobody may write: refused before the bake, like any bad output.
        for cmd, name, extra in (("bake", "out.vdb", BAKE), ("render", "p.png", RENDER)):
            target = os.path.join(readonly, name)
            p = run(cmd, open_in, "-o", target, *extra, check=None, preexec_fn=as_nobody)
            self.assertEqual(p.returncode, 2, p.stderr)
            self.assert_one_line(p.stderr, f"vdbscatter {cmd}: {target}: the folder {readonly} "
                                 "is not writable")
            self.assertEqual(os.listdir(readonly), [])
        # Another user's live process (PID 1: kill() says EPERM, not ESRCH) keeps its
        # temporary file; a dead process's goes.
        live, dead = f".out.vdb.tmp.1", f".out.vdb.tmp.{dead_pid()}"
        for name in (live, dead):
            write(os.path.join(shared, name), b"x")
        run("bake", open_in, "-o", out, *BAKE, preexec_fn=as_nobody)
        self.assertEqual(sorted(os.listdir(shared)), sorted([live, "out.vdb"]))
        self.assertEqual(self.assert_old_or_new(out, fresh=True), "new")


if __name__ == "__main__":
    unittest.main()
