"""Runs README.md as a newcomer would: every command block, in order, in a scratch copy.

The README's fenced blocks, by their info string:

* ```` ```sh ````: a bash script (`set -euo pipefail`), run as written.
* ```` ```console ````: a transcript. Each line `$ command` (continued by a trailing `\\`)
  runs; the lines after it, up to the next `$`, are output the command must print
  (stdout and stderr together, in order).
* ```` ```python ````: a script, run with the tests' Python as `__main__`.
* ```` ```text ```` after `<!-- output -->`: the output the previous run block must print.
* Anything else (``json``, ``rust``, ``text``, bare blocks) is not a command.

A run block right after `<!-- not run: REASON -->` is skipped, and the reason is required:
the demo and the test suite themselves, servers that wait for a browser, benchmarks that
take minutes or need FLINT, installs.

All blocks run in one scratch directory, in README order, so a later block sees an earlier
block's outputs, as a reader's shell would. The directory holds a copy of the repository's
tracked files (minus `src/`, `fuzz/` and the Rust tests; `tests/data` is kept), and `PATH`
starts with shims: `trimorph` is the binary under test (`TRIMORPH_BIN`), `python3` and
`python` are this interpreter, and `cargo run [--release] [--example NAME] -- ARGS` runs
the binary or the example already built beside it (`cargo build` is a no-op there);
`target/release/trimorph` and `target/debug/trimorph` are the binary under test too.

Expected output is matched line by line, in order, as a subsequence of the real output
(lines the README leaves out are allowed; `...` on a line of its own says so explicitly).
Within a line, `...` matches any text. Numbers are compared by value:

* integers exactly;
* decimals within `NUMBER_RTOL` (1 %) of the README's value, or within one and a half
  units of its last printed digit, whichever is larger;
* a number followed by a time or rate unit (`TIMING_UNITS`: ns, us, µs, ms, s, min,
  MP/s, MB/s, GB/s) is a machine-dependent timing, and any value matches.

Run it by hand with `python python/tests/readme_harness.py [--keep DIR]`; pytest runs it
in `test_readme_commands.py`.
"""

from __future__ import annotations

import os
import re
import shutil
import stat
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

#: Relative tolerance for decimal numbers the README quotes.
NUMBER_RTOL = 0.01
#: Units that make a number a machine-dependent timing (any value matches).
TIMING_UNITS = ("ns", "us", "µs", "ms", "s", "min", "MP/s", "MB/s", "GB/s")
#: Seconds one block may take before it counts as hung.
BLOCK_TIMEOUT = 600

#: Tracked paths not copied into the scratch directory (not inputs of any command).
SKIPPED_PREFIXES = ("src/", "fuzz/", "proptest-regressions/", ".ci/")


@dataclass
class Block:
    """One fenced block of the README."""

    kind: str  # "sh", "console", "python", "output"
    line: int  # 1-based line of the opening fence
    body: str
    skip: str | None = None  # the reason, for `<!-- not run: ... -->`
    expected: list[str] = field(default_factory=list)  # for "output"


def parse(text: str) -> list[Block]:
    """The run blocks (and output blocks) of a README, in order."""
    blocks: list[Block] = []
    lines = text.split("\n")
    i = 0
    pending_comment: str | None = None
    while i < len(lines):
        line = lines[i]
        stripped = line.strip()
        if stripped.startswith("<!--") and stripped.endswith("-->"):
            pending_comment = stripped[4:-3].strip()
            i += 1
            continue
        if stripped.startswith("```"):
            # A fence may be indented (a block inside a list item): so is its body.
            indent = len(line) - len(line.lstrip())
            info = stripped[3:].strip().split()
            lang = info[0] if info else ""
            start = i + 1
            j = i + 1
            while j < len(lines) and not lines[j].strip().startswith("```"):
                j += 1
            if j == len(lines):
                raise ValueError(f"README.md:{start}: fence never closed")
            body = "\n".join(_dedent(x, indent) for x in lines[i + 1 : j]) + "\n"
            comment = pending_comment
            pending_comment = None
            i = j + 1
            skip = None
            if comment is not None and comment.startswith("not run"):
                skip = comment[len("not run") :].lstrip(":").strip()
                if not skip:
                    raise ValueError(f"README.md:{start}: `not run` needs a reason")
            if lang in ("sh", "console", "python"):
                blocks.append(Block(lang, start, body, skip))
            elif lang == "text" and comment == "output":
                blocks.append(Block("output", start, body, expected=body.rstrip("\n").split("\n")))
            elif skip is not None:
                raise ValueError(f"README.md:{start}: `not run` on a block that is not a command")
            continue
        if stripped:
            pending_comment = None
        i += 1
    return blocks


def _dedent(line: str, indent: int) -> str:
    """`line` without the `indent` spaces of its (indented) fence."""
    if indent == 0 or not line[:indent].strip():
        return line[indent:]
    return line.lstrip()


def console_steps(body: str) -> list[tuple[str, list[str]]]:
    """A transcript's (command, expected output lines) pairs."""
    steps: list[tuple[str, list[str]]] = []
    lines = body.rstrip("\n").split("\n")
    i = 0
    while i < len(lines):
        if not lines[i].startswith("$ "):
            raise ValueError(f"transcript line {i + 1} is output before any command: {lines[i]!r}")
        cmd = lines[i][2:]
        while cmd.endswith("\\") and i + 1 < len(lines):
            i += 1
            cmd = cmd + "\n" + lines[i]
        i += 1
        out: list[str] = []
        while i < len(lines) and not lines[i].startswith("$ "):
            out.append(lines[i])
            i += 1
        steps.append((cmd, out))
    return steps


_NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?")
_UNITS = "|".join(re.escape(u) for u in sorted(TIMING_UNITS, key=len, reverse=True))
_TIMING = re.compile(rf"(-?\d+(?:\.\d+)?)(\s?)({_UNITS})(?![\w/])")


def _line_pattern(expected: str) -> tuple[re.Pattern, list[str | None]]:
    """A regex for one expected line, and per captured number its README text (None for a
    timing, which matches any value)."""
    parts: list[str] = []
    numbers: list[str | None] = []
    pos = 0
    # Tokens: `...`, timings, numbers; everything else literal with whitespace runs free.
    token = re.compile(rf"\.\.\.|{_TIMING.pattern}|{_NUMBER.pattern}")
    after_ellipsis = False
    for m in token.finditer(expected):
        text = m.group(0)
        before = expected[pos : m.start()]
        # Space next to `...` is part of what it stands for (`(fold-free) ...` matches
        # `(fold-free); gauss-newton ...`).
        if text == "...":
            before = before.rstrip()
        if after_ellipsis:
            before = before.lstrip()
        parts.append(_literal(before))
        after_ellipsis = text == "..."
        if text == "...":
            parts.append(".*?")
        elif m.group(3):  # a timing
            parts.append(r"(-?\d+(?:\.\d+)?)\s?" + re.escape(m.group(3)))
            numbers.append(None)
        else:
            # A number must not be glued to more digits on either side.
            parts.append(r"(?<![\d.])(-?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?)(?![\d])")
            numbers.append(text)
        pos = m.end()
    rest = expected[pos:]
    parts.append(_literal(rest.lstrip() if after_ellipsis else rest))
    return re.compile("^\\s*" + "".join(parts) + "\\s*$"), numbers


def _literal(text: str) -> str:
    return r"\s+".join(re.escape(w) for w in re.split(r"\s+", text)) if text.strip() else (
        r"\s*" if text else ""
    )


def number_matches(readme: str, actual: str) -> bool:
    """Whether a printed number agrees with the README's (see the module doc)."""
    if re.fullmatch(r"-?\d+", readme):
        return re.fullmatch(r"-?\d+", actual) is not None and int(readme) == int(actual)
    e, a = float(readme), float(actual)
    mantissa = readme.lower().split("e")[0]
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    exponent = int(readme.lower().split("e")[1]) if "e" in readme.lower() else 0
    ulp = 10.0 ** (exponent - decimals)
    return abs(a - e) <= max(NUMBER_RTOL * abs(e), 1.5 * ulp)


def line_matches(expected: str, actual: str) -> bool:
    pattern, numbers = _line_pattern(expected)
    m = pattern.match(actual)
    if not m:
        return False
    return all(
        want is None or number_matches(want, got) for want, got in zip(numbers, m.groups())
    )


def compare(expected: list[str], actual: str) -> str | None:
    """None if every expected line appears in `actual`, in order; else what is missing."""
    got = actual.rstrip("\n").split("\n")
    k = 0
    for want in expected:
        if want.strip() == "...":
            continue
        while k < len(got) and not line_matches(want, got[k]):
            k += 1
        if k == len(got):
            return f"expected line not printed (in order):\n  {want}\nactual output:\n" + "\n".join(
                "  " + g for g in got
            )
        k += 1
    return None


def _write_exec(path: Path, text: str) -> None:
    path.write_text(text)
    path.chmod(path.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)


def make_sandbox(root: Path, binary: Path) -> dict[str, str]:
    """Copies the tracked files into `root`, writes the shims, returns the environment."""
    files = subprocess.run(
        ["git", "ls-files", "-z"], cwd=REPO, check=True, capture_output=True
    ).stdout.decode().split("\0")
    for name in files:
        if not name or name.startswith(SKIPPED_PREFIXES):
            continue
        if name.startswith("tests/") and not name.startswith("tests/data/"):
            continue
        src = REPO / name
        if not src.is_file():
            continue
        dst = root / name
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dst)
    # Where `cargo build` would have put the binary: commands that name it find it there.
    for profile in ("release", "debug"):
        (root / "target" / profile).mkdir(parents=True)
        (root / "target" / profile / "trimorph").symlink_to(binary)
    shims = root / ".shims"
    shims.mkdir()
    (shims / "trimorph").symlink_to(binary)
    examples = binary.parent / "examples"
    for name in ("python3", "python"):
        _write_exec(shims / name, f'#!/bin/sh\nexec "{sys.executable}" "$@"\n')
    _write_exec(
        shims / "cargo",
        f"""#!/usr/bin/env bash
# The README's cargo commands, on the binaries already built (readme_harness.py).
set -euo pipefail
case "${{1:-}}" in
  build) exit 0 ;;
  run) shift ;;
  *) echo "readme harness: unsupported cargo command: cargo $*" >&2; exit 97 ;;
esac
example=""
while [ $# -gt 0 ] && [ "$1" != "--" ]; do
  case "$1" in
    --release|--quiet|-q) shift ;;
    --example) example="$2"; shift 2 ;;
    *) echo "readme harness: unsupported cargo run option $1" >&2; exit 97 ;;
  esac
done
[ $# -gt 0 ] && shift
if [ -n "$example" ]; then exec "{examples}/$example" "$@"; fi
exec "{binary}" "$@"
""",
    )
    env = dict(os.environ)
    env["PATH"] = f"{shims}{os.pathsep}{env.get('PATH', '')}"
    env.pop("TRIMORPH_TRACE", None)
    env["COLUMNS"] = "100"
    return env


@dataclass
class Outcome:
    block: Block
    ok: bool
    seconds: float
    message: str = ""


def run_block(block: Block, cwd: Path, env: dict[str, str], last_output: str) -> tuple[bool, str, str]:
    """(ok, message, output) for one block."""
    if block.kind == "output":
        problem = compare(block.expected, last_output)
        return problem is None, problem or "", last_output
    if block.kind == "python":
        script = cwd / f".readme_block_{block.line}.py"
        script.write_text(block.body)
        proc = subprocess.run(
            [sys.executable, script.name], cwd=cwd, env=env, capture_output=True, text=True,
            timeout=BLOCK_TIMEOUT,
        )
        out = proc.stdout + proc.stderr
        if proc.returncode != 0:
            return False, f"python block exited {proc.returncode}:\n{out}", out
        return True, "", proc.stdout
    if block.kind == "sh":
        proc = subprocess.run(
            ["bash", "-euo", "pipefail", "-c", block.body], cwd=cwd, env=env,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=BLOCK_TIMEOUT,
        )
        if proc.returncode != 0:
            return False, f"sh block exited {proc.returncode}:\n{proc.stdout}", proc.stdout
        return True, "", proc.stdout
    # A transcript: each command as its own shell, its output compared.
    out = ""
    for cmd, expected in console_steps(block.body):
        proc = subprocess.run(
            ["bash", "-o", "pipefail", "-c", cmd], cwd=cwd, env=env,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=BLOCK_TIMEOUT,
        )
        out = proc.stdout
        # A transcript may show a failing command on purpose (`...; echo $?` shows its code);
        # otherwise the command must succeed.
        if proc.returncode != 0:
            return False, f"`{cmd}` exited {proc.returncode}:\n{out}", out
        problem = compare(expected, out)
        if problem:
            return False, f"`{cmd}`: {problem}", out
    return True, "", out


def run_readme(work: Path, binary: Path, readme: Path = REPO / "README.md",
               report=print, until: int | None = None) -> list[Outcome]:
    """Runs every block of `readme` in a sandbox under `work`; one outcome per block.
    `until`: stop before the first block that starts after this README line."""
    blocks = parse(readme.read_text())
    if until is not None:
        blocks = [b for b in blocks if b.line <= until]
    env = make_sandbox(work, binary)
    outcomes: list[Outcome] = []
    last = ""
    for block in blocks:
        if block.skip is not None:
            outcomes.append(Outcome(block, True, 0.0, f"not run: {block.skip}"))
            continue
        t = time.monotonic()
        try:
            ok, message, last = run_block(block, work, env, last)
        except subprocess.TimeoutExpired:
            ok, message = False, f"timed out after {BLOCK_TIMEOUT} s"
        outcome = Outcome(block, ok, time.monotonic() - t, message)
        outcomes.append(outcome)
        report(f"README.md:{block.line} {block.kind}: {'ok' if ok else 'FAILED'} "
               f"({outcome.seconds:.1f} s)" + ("" if ok else "\n" + message))
    return outcomes


def default_binary() -> Path:
    env = os.environ.get("TRIMORPH_BIN")
    return Path(env) if env else REPO / "target" / "debug" / "trimorph"


if __name__ == "__main__":
    import argparse
    import tempfile

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--keep", type=Path, help="run in this (new) directory and keep it")
    ap.add_argument("--until", type=int, help="only the blocks up to this README line")
    args = ap.parse_args()
    if args.keep:
        args.keep.mkdir(parents=True)
        results = run_readme(args.keep, default_binary(), until=args.until)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            results = run_readme(Path(tmp), default_binary(), until=args.until)
    failed = [o for o in results if not o.ok]
    print(f"{len(results)} blocks, {len(failed)} failed")
    sys.exit(1 if failed else 0)
