"""vdbscatter from Python: the commands of the `vdbscatter` CLI as functions, through ctypes
over libvdbscatter.so (docs/python.md).

    import vdbscatter
    vdbscatter.sample("cloud", "cloud.vdb", res=32)
    report = vdbscatter.bake("cloud.vdb", "lit.vdb", sun=(0.3, -1, 0.2), density_scale=20)
    image = vdbscatter.render("lit.vdb", size=(320, 240))   # numpy (H, W, 3) float32
    grids = vdbscatter.read_lit("lit.vdb")                  # name -> Grid

Keywords are the CLI's long flags with dashes as underscores (density_scale=20 is
--density-scale 20); each function's help lists them, as `vdbscatter COMMAND --help` does.
"""
import collections
import ctypes
import difflib
import inspect
import json
import numbers
import os
import signal
import tempfile
import threading
import warnings

import numpy as np

from . import _lib

_LIB = _lib.load()

__version__ = _LIB.vdbs_version().decode()


class Error(Exception):
    """A command failed. message: the library's one-line message; status: its vdbs_status
    (2 bad input, 3 I/O, 4 GPU, 5 memory, 6 internal, 7 cancelled); exit_status: what the CLI
    would have exited with."""

    def __init__(self, message, status, exit_status):
        super().__init__(message)
        self.message = message
        self.status = status
        self.exit_status = exit_status


class InputError(Error):
    """Bad input: a missing or foreign file, a bad flag value, an unknown keyword (status 2,
    the CLI's exit 2)."""


class VdbscatterWarning(UserWarning):
    """A warning the command printed ("vdbscatter: warning: ..." on the CLI)."""


def _input_error(message):
    return InputError(message, _lib.ERR_INPUT, 2)


# ---- running one command ----

class _Outcome:
    """What a command left in its vdbs_command_result, copied out before it is freed."""

    def __init__(self, result, keep_image):
        self.exit_status = result.exit_status
        self.status = result.status
        self.error = result.error.decode("utf-8", "replace")
        self.output = ctypes.string_at(result.output, result.output_size) if result.output else b""
        self.rgb = self.se = None
        if keep_image and result.rgb:
            shape = (result.height, result.width, 3)
            self.rgb = np.ctypeslib.as_array(result.rgb, shape=shape).copy()
            if result.se:
                self.se = np.ctypeslib.as_array(result.se, shape=shape).copy()


def _wait_through_interrupts(finished):
    """Waits for the cancelled command to end; a second Ctrl-C does not abandon it (it is
    already stopping, and its result must still be freed)."""
    while not finished.is_set():
        try:
            finished.wait(0.1)
        except KeyboardInterrupt:
            pass


def _run(words, on_message=None, progress=False, keep_image=False):
    """Runs the command words ([command, args...]) in a worker thread and returns its
    _Outcome. on_message(kind, text_bytes) receives every message, on the worker thread; if
    it raises, the command is cancelled and the exception re-raised here. Ctrl-C in the main
    thread cancels the command, waits for it to stop (it removes its partial output) and
    re-raises KeyboardInterrupt."""
    argv = (ctypes.c_char_p * len(words))(*[os.fsencode(w) for w in words])
    cancel = _lib.Cancel(0)
    raised = []

    def message(user, kind, text):
        try:
            on_message(kind, text)
        except BaseException as e:  # the library cannot take an exception: stop it instead
            raised.append(e)
            cancel.value = signal.SIGINT

    desc = _lib.CommandDesc()
    desc.argc = len(words)
    desc.argv = argv
    desc.cancel = ctypes.pointer(cancel)
    desc.progress = 1 if progress else 0
    desc.keep_image = 1 if keep_image else 0
    # The callback object lives in this frame (and desc) until the worker has joined: the
    # library calls it until vdbs_command_run returns.
    callback = None
    if on_message:
        callback = _lib.MessageFn(message)
        desc.message = callback

    done = {}
    finished = threading.Event()

    def work():
        result = _lib.CommandResult()
        try:
            _LIB.vdbs_command_run(ctypes.byref(desc), ctypes.byref(result))
            done["outcome"] = _Outcome(result, keep_image)
        except BaseException as e:
            done["exception"] = e
        finally:
            _LIB.vdbs_command_result_free(ctypes.byref(result))
            finished.set()

    worker = threading.Thread(target=work, name=" ".join(["vdbscatter", *words[:1]]))
    worker.start()
    try:
        # Short timed waits, so that Ctrl-C is seen while the command works. On an Event,
        # not Thread.join(timeout): a KeyboardInterrupt inside join marks the thread as
        # finished while it still runs (CPython 3.11), and the wait below would end at once.
        while not finished.wait(0.1):
            pass
    except KeyboardInterrupt:
        cancel.value = signal.SIGINT
        _wait_through_interrupts(finished)
        raise
    finally:
        worker.join()
    if raised:
        raise raised[0]
    if "exception" in done:
        raise done["exception"]
    return done["outcome"]


# ---- keywords to command-line words ----

def _keyword(flag):
    return flag.lstrip("-").replace("-", "_")


def _option_table(command):
    """{keyword: (flag, kind)} from the library's option table of command."""
    table = {}
    info = _lib.ArgOption()
    for i in range(_LIB.vdbs_command_option_count(command.encode())):
        if _LIB.vdbs_command_option_get(command.encode(), i, ctypes.byref(info)) != _lib.OK:
            raise RuntimeError(f"vdbscatter: option {i} of {command} is missing")
        flag = info.name.decode()
        table[_keyword(flag)] = (flag, info.kind)
    if "o" in table:
        table["output"] = table["o"]
    return table


def _command_names():
    names = _LIB.vdbs_command_names()
    found = []
    while names[len(found)] is not None:
        found.append(names[len(found)].decode())
    return found


_COMMANDS = _command_names()
_OPTIONS = {command: _option_table(command) for command in _COMMANDS}


def _is_number(x):
    return isinstance(x, numbers.Real) and not isinstance(x, bool)


def _number(x):
    # repr of a float is the shortest text that reads back as the same double.
    return str(int(x)) if isinstance(x, numbers.Integral) else repr(float(x))


def _is_text(x):
    return isinstance(x, (str, bytes, os.PathLike))


def _is_numbers(x):
    return isinstance(x, (tuple, list)) and len(x) > 0 and all(_is_number(v) for v in x)


def _part(flag, x):
    """One ':'-separated part of a value: text, a number, or numbers joined by ','."""
    if _is_text(x):
        return os.fsdecode(x)
    if _is_number(x):
        return _number(x)
    if _is_numbers(x):
        return ",".join(_number(v) for v in x)
    raise _input_error(f"{flag}: cannot pass {x!r} (a str, a number or a tuple of numbers "
                       "per part)")


def _value(flag, value):
    """The text of one value: numbers or texts joined by ',' (albedo=(0.9, 0.8, 0.7),
    methods=("svd", "pop")), anything else part by part joined by ':' (sun=((0.3, -1, 0.2),
    (3, 3, 3)) is '0.3,-1,0.2:3,3,3'); size=(640, 480) is '640x480'."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (tuple, list)):
        return _part(flag, value)
    if not value:
        raise _input_error(f"{flag}: cannot pass an empty {type(value).__name__}")
    if flag == "--size" and _is_numbers(value) and len(value) == 2:
        return "x".join(_number(v) for v in value)
    if _is_numbers(value) or all(_is_text(v) for v in value):
        return ",".join(_part(flag, v) for v in value)
    return ":".join(_part(flag, v) for v in value)


def _is_repeated(value):
    """A list of values (for a repeatable flag) rather than one value: a list whose items
    are not all numbers (sun=[(0, -1, 0), (1, 0, 0)] is two suns)."""
    return isinstance(value, list) and not _is_numbers(value)


def _unknown_keyword(command, key):
    name = command.replace("-", "_")
    near = difflib.get_close_matches(key, _OPTIONS[command].keys(), n=1)
    hint = f"did you mean '{near[0]}'?" if near else f"see help(vdbscatter.{name})"
    return _input_error(f"unknown option '{key}' for {name} ({hint})")


def _option_words(command, options):
    """The command-line words of keyword options: True adds a flag, False and None leave
    an option out, a list gives a repeatable flag (--sun, --point, --env) once per item."""
    table = _OPTIONS[command]
    for key in options:
        if key not in table:
            raise _unknown_keyword(command, key)
    words = []
    for key, value in options.items():
        flag, kind = table[key]
        if value is None or value is False and kind == _lib.ARG_FLAG:
            continue
        if kind == _lib.ARG_FLAG:
            if value is not True:
                raise _input_error(f"{flag} is a flag: give True or False, not {value!r}")
            words.append(flag)
        elif isinstance(value, bool):
            raise _input_error(f"{flag} takes a value, not {value!r}")
        elif _is_repeated(value):
            if kind != _lib.ARG_LIST:
                raise _input_error(f"{flag} takes one value, not a list of {len(value)} (a "
                                   "tuple is one value)")
            for item in value:
                words += [flag, _value(flag, item)]
        else:
            words += [flag, _value(flag, value)]
    return words


def _write_scene(scene):
    """A scene dict as a temporary JSON file; returns the path to pass as --scene. The file
    goes into the current folder, named without a folder, so that relative paths in the dict
    mean what they mean to the caller (a scene's paths are relative to its file's folder);
    into the temporary folder where the current one is read-only."""
    try:
        fd, path = tempfile.mkstemp(prefix=".vdbscatter-scene-", suffix=".json", dir=".")
        path = os.path.basename(path)
    except OSError:
        fd, path = tempfile.mkstemp(prefix="vdbscatter-scene-", suffix=".json")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        json.dump(scene, f)
    return path


_WARNING_PREFIX = "vdbscatter: warning: "


def _call(command, positional, options, progress=None, keep_image=False):
    """Runs command with positional arguments and keyword options; raises Error (or
    InputError) when it fails, issues its warnings as VdbscatterWarning and returns its
    _Outcome. progress(line) receives each progress line (without '\\r' or '\\n')."""
    scene_file = None
    try:
        if isinstance(options.get("scene"), dict):
            scene_file = _write_scene(options["scene"])
            options = {**options, "scene": scene_file}
        words = [command, *(os.fspath(p) for p in positional if p is not None),
                 *_option_words(command, options)]
        found = []

        def on_message(kind, text):
            if kind == _lib.MESSAGE_WARNING:
                line = text.decode("utf-8", "replace").strip()
                found.append(line[len(_WARNING_PREFIX):] if line.startswith(_WARNING_PREFIX)
                             else line)
            elif kind == _lib.MESSAGE_PROGRESS and progress:
                line = text.decode("utf-8", "replace").strip("\r\n")
                if line:
                    progress(line)

        outcome = _run(words, on_message, progress=progress is not None, keep_image=keep_image)
    finally:
        if scene_file:
            os.remove(scene_file)
    for text in found:
        warnings.warn(text, VdbscatterWarning, stacklevel=3)
    if outcome.exit_status != 0:
        kind = InputError if outcome.status == _lib.ERR_INPUT else Error
        raise kind(outcome.error, outcome.status, outcome.exit_status)
    return outcome


def _report(outcome):
    return json.loads(outcome.output.decode("utf-8"))


# ---- the commands ----

def bake(input, output, *, progress=None, **options):
    """Bakes the in-scattered light of the density VDB `input` (None: the scene's volume)
    into the lit VDB `output` (`vdbscatter bake --json`); returns the JSON report as a
    dict. A frame sequence (a frame number in `input` and `output`, as "smoke.####.vdb", or
    frames="1-240") returns the sequence summary instead, each frame's report in its
    "frames" entry (docs/sequences.md). progress(line), when given, receives each progress
    line as the bake works."""
    return _report(_call("bake", [input], {**options, "o": output, "json": True}, progress))


def render(input, output=None, *, return_se=False, return_report=False, progress=None,
           **options):
    """Renders `input` (a density or lit VDB; None: the scene's volume) and returns the
    picture as a numpy float32 array (height, width, 3), linear RGB, row 0 on top; also
    writes `output` (.exr or .png) when given. return_se=True adds the per-pixel standard
    errors of mode='reference' (an array of the same shape; None in the other modes),
    return_report=True the --json summary (a dict): the result is then a tuple
    (image[, se][, report]). A frame sequence (a frame number in `input` and `output`, or
    frames=...) writes each frame's picture and returns the sequence summary (a dict).
    progress(line), when given, receives each progress line."""
    outcome = _call("render", [input], {**options, "o": output, "json": True}, progress,
                    keep_image=True)
    report = _report(outcome)
    if outcome.rgb is None and "frames_total" in report:
        return report
    if not (return_se or return_report):
        return outcome.rgb
    extra = [outcome.se] if return_se else []
    if return_report:
        extra.append(report)
    return (outcome.rgb, *extra)


def compare(a, b, **options):
    """Error metrics of image `a` against the reference image `b` (`vdbscatter compare
    --json`) as a dict; undefined values are None."""
    return _report(_call("compare", [a, b], {**options, "json": True}))


def info(path=None, **options):
    """The grids of the VDB `path` and its optical thickness (`vdbscatter info --json`) as a
    dict."""
    return _report(_call("info", [path], {**options, "json": True}))


def sample(name, output, **options):
    """Writes the procedural sample `name` (cloud, smoke, sphere, slab, cube; sky: an EXR
    environment map) to `output`; returns None."""
    _call("sample", [name], {**options, "o": output})


def phase_svd(**options):
    """The phase matrix's factorisation error per term (`vdbscatter phase-svd --json`) as a
    dict; g and directions are required."""
    return _report(_call("phase-svd", [], {**options, "json": True}))


def tradeoff(input, output, *, progress=None, **options):
    """Every method's error against time on the scene (`vdbscatter tradeoff --json`),
    written into the folder `output`; returns the table as a dict. progress(line), when
    given, receives each progress line."""
    return _report(_call("tradeoff", [input], {**options, "o": output, "json": True}, progress))


def _attach_help(function, command):
    """Appends the command's --help text, printed by the library itself, to the docstring:
    the keywords are the flags it lists."""
    text = _run([command, "--help"]).output.decode("utf-8")
    # cleandoc first: the help's lines start at column 0, the docstring's are indented.
    function.__doc__ = (
        inspect.cleandoc(function.__doc__) + "\n\n"
        "Keyword options are the flags below with dashes as underscores (--density-scale is\n"
        "density_scale=...), -o is output=..., -q is q=True (docs/python.md). The command's\n"
        "help:\n\n" + text)


for _function, _command in [(bake, "bake"), (render, "render"), (compare, "compare"),
                            (info, "info"), (sample, "sample"), (phase_svd, "phase-svd"),
                            (tradeoff, "tradeoff")]:
    _attach_help(_function, _command)
del _function, _command


# ---- dense grids ----

Grid = collections.namedtuple("Grid", "name values origin index_to_world")
Grid.__doc__ = """One grid of a VDB as a dense array over its active bounding box.
name: the grid's name; values: numpy float32 (z, y, x) or (z, y, x, 3), the grid's values
active or not (0 outside a lit VDB's active voxels); origin: the index (x, y, z) of
values[0, 0, 0]; index_to_world: 4x4 numpy array mapping index (x, y, z, 1) to world space."""


def _raise_dense(status, err):
    kind = InputError if status == _lib.ERR_INPUT else Error
    raise kind(err.message.decode("utf-8", "replace"), status,
               2 if status == _lib.ERR_INPUT else 1)


def _grid_from(grid):
    """A Grid holding copies of a vdbs_dense_grid's values and transform."""
    sx, sy, sz = grid.size
    shape = (sz, sy, sx) + ((3,) if grid.channels == 3 else ())
    if grid.values:
        values = np.ctypeslib.as_array(grid.values, shape=shape).copy()
    else:
        values = np.zeros(shape, np.float32)
    index_to_world = np.array([list(row) for row in grid.index_to_world] + [[0, 0, 0, 1]],
                              dtype=np.float64)
    return Grid(grid.name.decode("utf-8", "replace"), values, tuple(grid.origin), index_to_world)


def read_lit(path, max_memory=None):
    """Every float and vec3s grid of the VDB `path` (a lit VDB from bake, or any other) as
    {name: Grid}, from one reading of the file; grids of other types are left out, and of two
    grids with one name the first is read. The copies together must fit in max_memory bytes
    (None: the library's default limit, 75% of the machine's memory; a negative number: no
    limit)."""
    grids = ctypes.POINTER(_lib.DenseGrid)()
    count = ctypes.c_int(0)
    err = _lib.Error()
    limit = 0 if max_memory is None else int(max_memory)
    status = _LIB.vdbs_dense_read_all(os.fsencode(path), limit, ctypes.byref(grids),
                                      ctypes.byref(count), ctypes.byref(err))
    if status != _lib.OK:
        _raise_dense(status, err)
    try:
        return {grids[i].name.decode("utf-8", "replace"): _grid_from(grids[i])
                for i in range(count.value)}
    finally:
        _LIB.vdbs_dense_free_all(grids, count)


__all__ = ["Error", "InputError", "VdbscatterWarning", "Grid", "bake", "render", "compare",
           "info", "sample", "phase_svd", "tradeoff", "read_lit"]
