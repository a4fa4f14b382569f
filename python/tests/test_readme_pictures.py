"""Every picture of README.md is current: `docs/pictures.sh` makes them again from the
bundled data with the binary under test, and each must equal the committed one within
`PIXEL_TOLERANCE` (the pictures are deterministic: tiny-skia rendering, fixed seeds).

Pictures that the script does not make have their own check: the morph contact sheets of
`tests/it/morph/real.rs` (`doc_images_of_the_real_pair`), and the editor's browser screenshots
of `tests/it/server/editor_e2e.rs` (Chromium's rendering is not byte-stable, so they are only
checked to exist and to be referenced)."""

import os
import re
import subprocess

import numpy as np
import pytest
from PIL import Image

import readme_harness as h
from conftest import REPO

#: A regenerated picture may differ from the committed one by at most this many grey levels
#: in at most `PIXEL_SHARE` of its values (float rounding along an anti-aliased edge).
PIXEL_TOLERANCE = 2
PIXEL_SHARE = 0.001

#: docs/img pictures made elsewhere, and the test that makes or checks them.
ELSEWHERE = {
    "morph_real_contact.png": "tests/it/morph/real.rs",
    "morph_delaunay_contact.png": "tests/it/morph/real.rs",
    "editor.png": "tests/it/server/editor_e2e.rs",
    "editor_warp.png": "tests/it/server/editor_e2e.rs",
    "editor_z1.png": "tests/it/server/editor_e2e.rs",
    "editor_landmarks.png": "tests/it/server/editor_e2e.rs",
    "editor_two.png": "tests/it/server/editor_e2e.rs",
    "editor_two_colors.png": "tests/it/server/editor_e2e.rs",
    "napari.png": "napari/examples/screenshot.py",
}


def readme_pictures() -> set[str]:
    text = (REPO / "README.md").read_text()
    return set(re.findall(r"\(docs/img/([\w.-]+)\)", text))


def test_every_picture_in_docs_img_is_in_the_readme_and_the_other_way_round():
    on_disk = {p.name for p in (REPO / "docs" / "img").iterdir()}
    assert readme_pictures() == on_disk


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory, trimorph_bin):
    work = tmp_path_factory.mktemp("pictures")
    env = h.make_sandbox(work, trimorph_bin)
    env["PYTHON"] = os.environ.get("PYTHON", "python3")
    out = work / "pictures"
    subprocess.run(["bash", "docs/pictures.sh", str(out)], cwd=work, env=env, check=True,
                   timeout=1800)
    return out


def test_the_script_makes_every_readme_picture_not_made_elsewhere(regenerated):
    made = {p.name for p in regenerated.iterdir()}
    assert made == readme_pictures() - set(ELSEWHERE)


def picture_difference(committed, fresh) -> str | None:
    a, b = np.asarray(Image.open(committed)), np.asarray(Image.open(fresh))
    if a.shape != b.shape:
        return f"shape {b.shape}, committed {a.shape}"
    d = np.abs(a.astype(np.int32) - b.astype(np.int32))
    share = float((d > PIXEL_TOLERANCE).mean())
    if share > PIXEL_SHARE:
        return f"{share:.2%} of the values differ by more than {PIXEL_TOLERANCE} (max {d.max()})"
    return None


def test_every_regenerated_picture_equals_the_committed_one(regenerated):
    stale = {}
    for fresh in sorted(regenerated.iterdir()):
        committed = REPO / "docs" / "img" / fresh.name
        if fresh.suffix == ".svg":
            problem = None if fresh.read_bytes() == committed.read_bytes() else "bytes differ"
        else:
            problem = picture_difference(committed, fresh)
        if problem:
            stale[fresh.name] = problem
    assert not stale, f"stale pictures (run docs/pictures.sh --update): {stale}"


def test_pictures_made_elsewhere_name_a_test_that_makes_them():
    for name, test in ELSEWHERE.items():
        assert (REPO / "docs" / "img" / name).is_file(), name
        assert name.split("_")[0] in (REPO / test).read_text() or name in (REPO / test).read_text()
