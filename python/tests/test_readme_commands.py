"""README.md runs as written: every command block in order, every quoted output compared
(`readme_harness.py` says how), plus the harness's own rules checked on small inputs."""

import re

import pytest

import readme_harness as h
from conftest import REPO


def test_every_readme_command_runs_and_prints_what_the_readme_says(tmp_path, trimorph_bin):
    outcomes = h.run_readme(tmp_path, trimorph_bin, report=lambda _: None)
    failed = [o for o in outcomes if not o.ok]
    ran = [o for o in outcomes if o.ok and o.block.skip is None]
    assert len(ran) >= 30, f"only {len(ran)} blocks ran: the README lost its commands?"
    assert not failed, "\n\n".join(
        f"README.md:{o.block.line} ({o.block.kind}): {o.message}" for o in failed
    )


def test_every_skipped_readme_block_says_why():
    blocks = h.parse((REPO / "README.md").read_text())
    skipped = [b for b in blocks if b.skip is not None]
    assert all(len(b.skip) > 10 for b in skipped), [b.line for b in skipped]
    # Skipping is the exception: most command blocks run.
    assert len(skipped) * 4 < len(blocks)


def test_the_readme_has_no_unlabelled_code_blocks():
    """Every fence names its language, so no command hides in a block the harness skips."""
    # Closing fences are bare; openings must not be: count them in pairs (indented fences,
    # inside list items, included).
    lines = (REPO / "README.md").read_text().split("\n")
    inside, unlabelled, fences = False, [], 0
    for i, line in enumerate(lines):
        if line.strip().startswith("```"):
            fences += 1
            if not inside and line.strip() == "```":
                unlabelled.append(i + 1)
            inside = not inside
    assert not unlabelled, f"README.md lines {unlabelled} open a block without a language"
    assert fences > 100 and not inside


@pytest.mark.parametrize(
    "expected, actual, ok",
    [
        ("rms 18.696 px", "rms 18.696 px", True),
        ("rms 18.696 px", "rms 18.8 px", True),  # within 1 %
        ("rms 18.696 px", "rms 19.9 px", False),
        ("0.000 px", "0.001 px", True),  # 1.5 units of the last digit
        ("0.000 px", "0.002 px", False),
        ("151 iterations", "146 iterations", False),  # integers exactly
        ("in 568 ms", "in 8330 ms", True),  # a timing
        ("(5 MP/s)", "(3 MP/s)", True),
        ("C1 holds (... conditions exactly 0)", "C1 holds (480 of 480 conditions exactly 0)", True),
        ("(fold-free) ...", "(fold-free); gauss-newton (1 iterations)", True),
        ("fit6.json: C1 holds", "fit7.json: C1 holds", False),
        ("det J -2.1278", "det J 2.1278", False),
    ],
)
def test_line_matching_rules(expected, actual, ok):
    assert h.line_matches(expected, actual) is ok


def test_output_lines_must_appear_in_order():
    out = "a 1\nb 2\nc 3\n"
    assert h.compare(["a 1", "c 3"], out) is None
    assert h.compare(["c 3", "a 1"], out) is not None
    assert h.compare(["a 1", "...", "c 3"], out) is None


def test_a_transcript_without_a_command_is_refused():
    with pytest.raises(ValueError):
        h.console_steps("output first\n$ true\n")


def test_not_run_needs_a_reason():
    with pytest.raises(ValueError):
        h.parse("<!-- not run -->\n```sh\ntrue\n```\n")
    blocks = h.parse("<!-- not run: a server -->\n```sh\ntrue\n```\n```console\n$ echo 1\n1\n```\n")
    assert [b.skip for b in blocks] == ["a server", None]


def github_slug(heading: str) -> str:
    """GitHub's anchor for a Markdown heading: lower case, punctuation dropped (but `-` and
    `_`), spaces to `-`."""
    text = heading.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def test_every_link_to_a_readme_section_names_a_heading():
    text = (REPO / "README.md").read_text()
    lines, inside = [], False
    for line in text.split("\n"):
        if line.strip().startswith("```"):
            inside = not inside
        elif not inside:
            lines.append(line)
    slugs = {github_slug(m.group(1)) for m in re.finditer(r"^#+ (.*)$", "\n".join(lines), re.M)}
    links = set(re.findall(r"\]\(#([^)]+)\)", text))
    assert links, "the contents list links to sections"
    assert not links - slugs, f"links to no heading: {sorted(links - slugs)}"
