#!/usr/bin/python3
"""ctest doc_commands: the commands and pictures of README.md and docs/*.md still match the repository.

    tests/docs/test_doc_commands.py SOURCE_DIR BIN_DIR

Reads every fenced shell block (```sh, ```bash, ```console, or an untagged block whose lines start with
`mlcg`, `build/bin/...` or `scripts/...`) and checks, for every command line in it:
  - each `mlcg SUB` names a subcommand of `BIN_DIR/mlcg --help`, and each `--option` after it appears in
    `BIN_DIR/mlcg SUB --help` (for `mlcg submit`, options after the case go to sbatch: see SBATCH);
  - every repository path it names (cases/, scripts/, tests/, docs/, bench/) exists;
  - `mlcg check CASE` exits 0 for every case file (.toml under cases/) it names.
Also: every image a page shows exists, is a PNG (magic bytes) and is under 300 KB; no link or path in
README.md or docs/ leaves the repository (a relative link climbing out of the root, or an absolute path
such as /work or /home). Prints one line per failure and exits 1 if there is any.
"""
import re
import shlex
import subprocess
import sys
from pathlib import Path

MAX_PNG = 300 * 1024
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
SHELL_TAGS = {"sh", "bash", "console", "shell"}
COMMAND_START = re.compile(r"^(\$ )?(mlcg|build/bin/|scripts/)")
REPO_PATH = re.compile(r"^(cases|scripts|tests|docs|bench)/")
# `mlcg submit CASE [--out RUN] [--quiet] [sbatch options]`: the sbatch options the docs show.
SBATCH = {"--partition", "--time"}
# Absolute paths a page may show: system programs and files, not a machine's own folders.
ABSOLUTE_OK = ("/usr/", "/proc/", "/sys/", "/etc/", "/dev/", "/path/to/")


class Checker:
    def __init__(self, root, bindir):
        self.root = root
        self.mlcg = bindir / "mlcg"
        self.failures = []
        self.help = {}
        self.checked_cases = {}

    def fail(self, where, msg):
        self.failures.append(f"{where}: {msg}")
        print(f"FAIL {where}: {msg}")

    def help_text(self, sub):
        if sub not in self.help:
            cmd = [str(self.mlcg)] + ([sub] if sub else []) + ["--help"]
            p = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
            self.help[sub] = p.stdout + p.stderr if p.returncode == 0 else None
        return self.help[sub]

    def subcommands(self):
        text = self.help_text("") or ""
        # CLI11 lists them under "Subcommands:", one per line: "  run   run a case"
        part = re.split(r"^subcommands:", text, maxsplit=1, flags=re.I | re.M)[-1]
        return {m.group(1) for m in re.finditer(r"^\s+([a-z][a-z_-]*)\b", part, re.M)}

    def check_case(self, where, case):
        if case not in self.checked_cases:
            p = subprocess.run([str(self.mlcg), "check", case, "--no-calibrate"], cwd=self.root,
                               capture_output=True, text=True, timeout=300)
            self.checked_cases[case] = (p.returncode, (p.stdout + p.stderr).strip().splitlines()[-1:])
        rc, last = self.checked_cases[case]
        if rc != 0:
            self.fail(where, f"`mlcg check {case}` exited {rc}: {' '.join(last)}")

    def check_paths(self, where, tokens):
        for tok in tokens:
            for part in re.split(r"[=,]", tok):
                part = part.rstrip(".,;:)")
                if REPO_PATH.match(part) and "<" not in part and "*" not in part:
                    if not (self.root / part).exists():
                        self.fail(where, f"`{part}` does not exist in the repository")

    def check_mlcg(self, where, tokens):
        # tokens[0] is mlcg or build/bin/mlcg
        if len(tokens) < 2 or tokens[1].startswith("-"):
            return
        sub = tokens[1]
        if sub not in self.subcommands():
            self.fail(where, f"`mlcg {sub}`: no such subcommand (mlcg --help lists {sorted(self.subcommands())})")
            return
        help_text = self.help_text(sub) or ""
        for tok in tokens[2:]:
            if not tok.startswith("--"):
                continue
            opt = tok.split("=", 1)[0]
            if sub == "submit" and opt in SBATCH:
                continue
            if not re.search(re.escape(opt) + r"\b", help_text):
                self.fail(where, f"`mlcg {sub} {opt}`: not in `mlcg {sub} --help`")
        if sub in ("check", "run", "submit"):
            for tok in tokens[2:]:
                if tok.startswith("cases/") and tok.endswith(".toml"):
                    self.check_case(where, tok)

    def command_lines(self, text):
        """(line number, command) of every command line of a shell block; continuation lines joined."""
        lines = text.splitlines()
        i = 0
        while i < len(lines):
            m = re.match(r"^\s*```(\w*)\s*$", lines[i])
            if not m:
                i += 1
                continue
            tag, start = m.group(1), i + 1
            j = start
            while j < len(lines) and not re.match(r"^\s*```\s*$", lines[j]):
                j += 1
            body = lines[start:j]
            stripped = [b.strip() for b in body if b.strip()]
            if tag in SHELL_TAGS or (tag == "" and stripped and all(COMMAND_START.match(b) or b.endswith("\\")
                                                                   or lines_continue(body, b) for b in stripped)):
                cmd, first = "", None
                for k, b in enumerate(body):
                    s = b.strip()
                    if first is None:
                        first = start + k + 1
                    cmd += " " + s.rstrip("\\")
                    if s.endswith("\\"):
                        continue
                    yield first, cmd.strip()
                    cmd, first = "", None
            i = j + 1

    def check_page(self, page):
        rel = page.relative_to(self.root)
        text = page.read_text()
        for lineno, cmd in self.command_lines(text):
            where = f"{rel}:{lineno}"
            cmd = re.sub(r"^\$ ", "", cmd.split("  #")[0].split(" # ")[0]).strip()
            if not cmd or cmd.startswith("#"):
                continue
            for piece in re.split(r"\s*(?:&&|\|\||;|\|)\s*", cmd):
                try:
                    tokens = shlex.split(piece)
                except ValueError:
                    tokens = piece.split()
                if not tokens:
                    continue
                self.check_paths(where, tokens)
                if tokens[0] in ("mlcg", "build/bin/mlcg"):
                    self.check_mlcg(where, tokens)
        self.check_links(page, rel, text)

    def check_links(self, page, rel, text):
        for lineno, line in enumerate(text.splitlines(), 1):
            where = f"{rel}:{lineno}"
            for m in re.finditer(r"(!?)\[[^\]]*\]\(([^)\s]+)\)", line):
                image, target = m.group(1), m.group(2)
                if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                    continue
                path = target.split("#", 1)[0]
                resolved = (page.parent / path).resolve()
                if path.startswith("/") or not resolved.is_relative_to(self.root):
                    self.fail(where, f"link `{target}` leaves the repository")
                    continue
                if not resolved.exists():
                    self.fail(where, f"link `{target}` names a missing file")
                elif image:
                    self.check_png(where, resolved)
            for m in re.finditer(r"(?<![\w.>])(\.\./[^\s`)\]\"']*)", line):
                # a ../ path anywhere in the text: it must stay inside the repository
                if not (page.parent / m.group(1)).resolve().is_relative_to(self.root):
                    self.fail(where, f"path `{m.group(1)}` leaves the repository")
            for m in re.finditer(r"(?<![\w.~/<>-])(/(?:work|home|root|tmp|mnt|opt|srv)(?:/[^\s`)\]\"']*)?)", line):
                self.fail(where, f"absolute path `{m.group(1)}`: the docs may only name files in the repository")

    def check_png(self, where, path):
        data = path.read_bytes()
        if not data.startswith(PNG_MAGIC):
            self.fail(where, f"{path.relative_to(self.root)} is not a PNG")
        if len(data) >= MAX_PNG:
            self.fail(where, f"{path.relative_to(self.root)} is {len(data) // 1024} KB, over 300 KB")


def lines_continue(body, line):
    """An untagged block's line that continues the previous line's command (after a trailing backslash)."""
    idx = [b.strip() for b in body].index(line)
    return idx > 0 and body[idx - 1].rstrip().endswith("\\")


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    root, bindir = Path(sys.argv[1]).resolve(), Path(sys.argv[2]).resolve()
    c = Checker(root, bindir)
    if c.help_text("") is None:
        print(f"FAILED: {c.mlcg} --help did not run")
        return 1
    pages = [root / "README.md"] + sorted((root / "docs").glob("*.md"))
    for page in pages:
        c.check_page(page)
    print(f"{len(pages)} pages, {len(c.checked_cases)} cases checked with `mlcg check`, "
          f"{len(c.help) - 1} subcommands' --help read: {len(c.failures)} failure(s)")
    return 1 if c.failures else 0


if __name__ == "__main__":
    sys.exit(main())
