#!/usr/bin/python3
"""The documentation against the code: README's quick-start commands run as written,
docs/cli.md lists exactly the flags each command's --help prints, README stays one page, no
page cites documents outside the repository, and relative links resolve."""
import os
import re
import shlex
import shutil
import subprocess
import tempfile
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLI = os.environ["VDBSCATTER"]
VIEW = os.environ["VDBSCATTER_VIEW"]
SAMPLES = os.environ.get("VDBSCATTER_SAMPLES_DIR", os.path.join(ROOT, "samples"))
TMP = os.environ.get("VDBSCATTER_TMP", tempfile.gettempdir())

README = os.path.join(ROOT, "README.md")
CLI_MD = os.path.join(ROOT, "docs", "cli.md")
COMMANDS = ["bake", "render", "compare", "info", "sample", "tradeoff", "phase-svd"]
FLAG = re.compile(r"(?<![\w-])(--[a-z0-9][a-z0-9-]*|-o|-q)(?![\w-])")


def read(path):
    with open(path, encoding="utf-8") as f:
        return f.read()


def code_blocks(markdown):
    """The fenced code blocks of a Markdown text, as lists of lines."""
    blocks, block = [], None
    for line in markdown.splitlines():
        if line.startswith("```"):
            if block is None:
                block = []
            else:
                blocks.append(block)
                block = None
        elif block is not None:
            block.append(line)
    return blocks


def readme_commands():
    """Every vdbscatter command line of README's code blocks, in order."""
    lines = []
    for block in code_blocks(read(README)):
        for line in block:
            line = line.strip()
            if line.startswith("./build/vdbscatter ") or line.startswith("vdbscatter "):
                lines.append(line)
    return lines


def flags(text):
    return set(FLAG.findall(text))


def help_text(argv):
    run = subprocess.run(argv + ["--help"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         universal_newlines=True, timeout=60)
    if run.returncode != 0:
        raise AssertionError(f"{argv} --help exited {run.returncode}: {run.stderr}")
    return run.stdout


def cli_md_sections():
    """docs/cli.md split at its '## NAME' headings: {NAME: text}."""
    sections, name = {}, None
    for line in read(CLI_MD).splitlines():
        m = re.match(r"^## (\S+)\s*$", line)
        if m:
            name = m.group(1)
            sections[name] = ""
        elif name:
            sections[name] += line + "\n"
    return sections


class ReadmeCommands(unittest.TestCase):
    def test_quick_start_runs(self):
        """README's vdbscatter lines, run in order in a scratch folder whose `samples` is the
        repository's, exit 0 and write every -o file. Output folders are created first, as
        demo.sh does."""
        commands = readme_commands()
        self.assertGreaterEqual(len(commands), 3, "README has no quick-start commands")
        work = tempfile.mkdtemp(prefix="readme_", dir=TMP)
        try:
            os.symlink(SAMPLES, os.path.join(work, "samples"))
            failures = []
            for line in commands:
                argv = shlex.split(line)
                argv[0] = CLI
                outputs = [argv[i + 1] for i, a in enumerate(argv[:-1]) if a in ("-o", "--output")]
                outputs += [a.split("=", 1)[1] for a in argv if a.startswith("--output=")]
                for out in outputs:
                    os.makedirs(os.path.dirname(os.path.join(work, out)), exist_ok=True)
                run = subprocess.run(argv, cwd=work, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, universal_newlines=True,
                                     timeout=600)
                if run.returncode != 0:
                    failures.append(f"exit {run.returncode}: {line}\n  {run.stderr.strip()[-1000:]}")
                for out in outputs:
                    if not os.path.isfile(os.path.join(work, out)):
                        failures.append(f"no {out} written: {line}")
            if failures:
                self.fail("README commands failed:\n" + "\n".join(failures))
        finally:
            shutil.rmtree(work, ignore_errors=True)


class CliReference(unittest.TestCase):
    def setUp(self):
        self.sections = cli_md_sections()

    def check(self, name, argv):
        self.assertIn(name, self.sections, f"docs/cli.md has no section '## {name}'")
        printed = flags(help_text(argv))
        documented = flags(self.sections[name])
        self.assertTrue(printed, f"{name} --help prints no flags")
        self.assertEqual(sorted(printed - documented), [],
                         f"docs/cli.md '{name}' lacks flags that --help prints "
                         "(run scripts/gen_cli_md.py BUILD_DIR)")
        self.assertEqual(sorted(documented - printed), [],
                         f"docs/cli.md '{name}' lists flags that --help does not print "
                         "(run scripts/gen_cli_md.py BUILD_DIR)")

    def test_commands(self):
        for command in COMMANDS:
            with self.subTest(command=command):
                self.check(command, [CLI, command])

    def test_viewer(self):
        self.check("vdbscatter-view", [VIEW])


class Pages(unittest.TestCase):
    def pages(self):
        yield README
        for folder, _, files in os.walk(os.path.join(ROOT, "docs")):
            for f in sorted(files):
                if f.endswith(".md"):
                    yield os.path.join(folder, f)

    def test_readme_is_one_page(self):
        self.assertLessEqual(len(read(README).splitlines()), 160)

    def test_no_outside_documents(self):
        banned = re.compile(r"DESIGN\.md|TOOLCHAIN|[Tt]he issue|shared/papers")
        for page in self.pages():
            for n, line in enumerate(read(page).splitlines(), 1):
                self.assertIsNone(banned.search(line),
                                  f"{os.path.relpath(page, ROOT)}:{n} cites an outside "
                                  f"document: {line.strip()}")

    def test_relative_links_resolve(self):
        """Every relative link names an existing file, and its #anchor a heading there
        (GitHub's slugs: lower case, punctuation dropped, spaces to hyphens)."""
        link = re.compile(r"\]\(([^)\s]+)\)")

        def anchors(path):
            if not path.endswith(".md"):
                return set()
            return {re.sub(r"[^\w\- ]", "", line.lstrip("#").strip().lower()).replace(" ", "-")
                    for line in read(path).splitlines() if line.startswith("#")}

        for page in self.pages():
            for target in link.findall(read(page)):
                if re.match(r"^[a-z]+:", target):
                    continue
                file, _, anchor = target.partition("#")
                path = os.path.normpath(os.path.join(os.path.dirname(page), file)) if file \
                    else page
                where = os.path.relpath(page, ROOT)
                self.assertTrue(os.path.exists(path), f"{where} links to missing {target}")
                if anchor:
                    self.assertIn(anchor, anchors(path), f"{where}: no heading for {target}")

if __name__ == "__main__":
    unittest.main(verbosity=2)
