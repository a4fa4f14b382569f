"""`trimorph.FrameSequence` and `fit_frames` (a sequence fit on Dask) against
`trimorph fit --frames`, frame by frame, on the bundled time-lapse (`trimorph demo` part 4:
the real nuclei frames of data/microscopy/timelapse, their per-frame landmarks from the
tracks, and the worm model bound to an 8x8-cell scene; see data/SOURCES.md).
"""

import json
import pickle
import shutil

import pytest

import trimorph
from trimorph._dask_fit import fit_frames

distributed = pytest.importorskip("dask.distributed")

FRAMES_INDEPENDENT = 6
FRAMES_TRACKED = 4


@pytest.fixture(scope="module")
def demo(tmp_path_factory, cli):
    """The demo's sequence inputs: scene.json (with its worm model), frames/, landmarks/."""
    root = tmp_path_factory.mktemp("demo")
    cli("demo", "-o", root)
    fit = root / "fit"
    # Fewer frames keep the test short: the first ones of the demo's ten.
    for n, sub in [(FRAMES_INDEPENDENT, "frames6"), (FRAMES_TRACKED, "frames4")]:
        (fit / sub).mkdir()
        for k in range(n):
            shutil.copy(fit / "frames" / f"frame_{k:02}.png", fit / sub / f"frame_{k:02}.png")
    return fit


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def _without_timing(v):
    """A report without its wall-clock keys (`*_ms`), the `status` and `reason` that
    `run_frame` adds."""
    if isinstance(v, dict):
        return {
            k: _without_timing(x)
            for k, x in v.items()
            if not k.endswith("_ms") and k not in ("status", "reason")
        }
    if isinstance(v, list):
        return [_without_timing(x) for x in v]
    return v


def _assert_same_outputs(names, cli_out, dask_out, results):
    assert [r["frame"] for r in results] == names
    for name, r in zip(names, results):
        assert (dask_out / f"{name}.json").read_text() == (cli_out / f"{name}.json").read_text()
        for ext in ["registered.png", "overlay.png", "obj"]:
            a, b = dask_out / f"{name}.{ext}", cli_out / f"{name}.{ext}"
            assert a.read_bytes() == b.read_bytes(), f"{name}.{ext} differs"
        ref = json.loads((cli_out / f"{name}.report.json").read_text())
        mine = json.loads((dask_out / f"{name}.report.json").read_text())
        assert _without_timing(mine) == _without_timing(ref), name
        # The returned dict is the written report (and the fitted frame's time is real).
        assert _without_timing(r) == _without_timing(mine)
        assert r["time_ms"] > 0
    # Nothing but the outputs: no temporary files left behind.
    assert sorted(p.name for p in dask_out.iterdir()) == sorted(
        p.name for p in cli_out.iterdir()
    )


def test_independent_frames_equal_cli_and_a_rerun_resumes(demo, cli, client, tmp_path):
    frames, lms, scene = demo / "frames6", demo / "landmarks", demo / "scene.json"
    cli_out, dask_out = tmp_path / "cli", tmp_path / "dask"
    cli("fit", "--model", scene, "--frames", frames, "--landmarks", lms, "-o", cli_out)
    res = fit_frames(scene, frames, lms, dask_out, client=client)
    names = [f"frame_{k:02}" for k in range(FRAMES_INDEPENDENT)]
    assert [r["status"] for r in res] == ["fitted"] * FRAMES_INDEPENDENT
    assert all(r["reason"] == "new" for r in res)
    _assert_same_outputs(names, cli_out, dask_out, res)

    # A rerun skips every current frame and leaves the files alone.
    before = {p.name: p.stat().st_mtime_ns for p in dask_out.iterdir()}
    again = fit_frames(scene, frames, lms, dask_out, client=client)
    assert [r["status"] for r in again] == ["skipped"] * FRAMES_INDEPENDENT
    assert all(r["reason"] is None for r in again)
    assert {p.name: p.stat().st_mtime_ns for p in dask_out.iterdir()} == before

    # A lost output (a task killed mid-frame, a deleted file) is refitted, and only that one.
    (dask_out / "frame_03.registered.png").unlink()
    third = fit_frames(scene, frames, lms, dask_out, client=client)
    assert [r["status"] for r in third] == ["skipped"] * 3 + ["fitted"] + ["skipped"] * 2
    assert "frame_03.registered.png" in third[3]["reason"]
    _assert_same_outputs(names, cli_out, dask_out, third)

    # The CLI agrees that the Dask run's outputs are current.
    p = cli("fit", "--model", scene, "--frames", frames, "--landmarks", lms, "-o", dask_out)
    assert f"0 frames fitted, {FRAMES_INDEPENDENT} skipped" in p.stdout, p.stdout


def test_tracked_sequence_is_a_chain_of_batches_equal_to_cli(demo, cli, client, tmp_path):
    frames, scene = demo / "frames4", demo / "scene.json"
    first = demo / "landmarks" / "frame_00.csv"
    cli_out, dask_out = tmp_path / "cli", tmp_path / "dask"
    opts = ["--track", "--anchor", "first", "--holdout", "2", "--seed", "3"]
    cli("fit", "--model", scene, "--frames", frames, "--landmarks", first, "-o", cli_out, *opts)
    res = fit_frames(
        scene, frames, first, dask_out, client=client, track=True, anchor="first",
        holdout=2, seed=3, batch=3,
    )
    names = [f"frame_{k:02}" for k in range(FRAMES_TRACKED)]
    assert [r["status"] for r in res] == ["fitted"] * FRAMES_TRACKED
    assert all(r["anchor"] == "first" for r in res)
    # Two held out in the first frame; later frames lose those the tracker loses.
    assert res[0]["holdout"]["tre"]["count"] == 2
    assert all(1 <= r["holdout"]["tre"]["count"] <= 2 for r in res)
    _assert_same_outputs(names, cli_out, dask_out, res)


def test_the_sequence_pickles_and_runs_one_frame_as_the_cli(demo, cli, tmp_path):
    frames, lms, scene = demo / "frames4", demo / "landmarks", demo / "scene.json"
    seq = trimorph.FrameSequence(scene, frames, lms, tmp_path / "py", bend=0.01)
    back = pickle.loads(pickle.dumps(seq))
    assert len(back) == len(seq) == FRAMES_TRACKED
    assert back.names == seq.names == [f"frame_{k:02}" for k in range(FRAMES_TRACKED)]
    assert back.out_dir == seq.out_dir and not back.tracked
    r = back.run_frame(2)
    assert r["status"] == "fitted" and r["frame"] == "frame_02"
    assert seq.run_frame(2)["status"] == "skipped"
    with pytest.raises(IndexError, match="frame 4 does not exist"):
        seq.run_frame(4)
    cli_out = tmp_path / "cli"
    cli("fit", "--model", scene, "--frames", frames, "--landmarks", lms, "-o", cli_out,
        "--bend", "0.01")
    for ext in ["json", "registered.png", "overlay.png", "obj"]:
        assert (tmp_path / "py" / f"frame_02.{ext}").read_bytes() == (
            cli_out / f"frame_02.{ext}"
        ).read_bytes(), ext


def test_bad_input_raises_a_value_error_naming_the_file(demo, tmp_path):
    frames, scene = demo / "frames4", demo / "scene.json"
    bad = tmp_path / "bad.csv"
    bad.write_text("name,src_x,src_y,dst_x,dst_y\nm,1,1,two,2\n")
    with pytest.raises(ValueError, match=str(bad)):
        fit_frames(scene, frames, bad, tmp_path / "out")
    assert not (tmp_path / "out").exists()
    empty = tmp_path / "no_frames"
    empty.mkdir()
    with pytest.raises(ValueError, match=f"no image files .* in {empty}"):
        fit_frames(scene, empty, demo / "landmarks", tmp_path / "out")
    with pytest.raises(ValueError, match="add --track"):
        fit_frames(scene, frames, demo / "landmarks", tmp_path / "out", anchor="first")
    with pytest.raises(ValueError, match="batch must be a whole number of frames >= 1"):
        fit_frames(scene, frames, demo / "landmarks", tmp_path / "out", batch=0)
    with pytest.raises(ValueError, match="no landmarks for frame frame_00"):
        fit_frames(scene, frames, tmp_path, tmp_path / "out")


def test_a_2d_sequence_needs_no_scene(demo, cli, tmp_path):
    """Issue 52: `model=None, size=(w, h)` is `trimorph fit --size W,H --frames`: the scene
    is the identity over a mesh adapted to the landmarks, made from the inputs alone."""
    frames, lms = demo / "frames4", demo / "landmarks"
    seq = trimorph.FrameSequence(None, frames, lms, tmp_path / "py", size=(511, 511), bend=0.01)
    back = pickle.loads(pickle.dumps(seq))
    assert len(back) == FRAMES_TRACKED
    assert back.run_frame(1)["status"] == "fitted"
    cli_out = tmp_path / "cli"
    cli("fit", "--size", "511,511", "--frames", frames, "--landmarks", lms, "-o", cli_out,
        "--bend", "0.01")
    for ext in ["json", "registered.png"]:
        assert (tmp_path / "py" / f"frame_01.{ext}").read_bytes() == (
            cli_out / f"frame_01.{ext}"
        ).read_bytes(), ext
    assert json.loads((cli_out / "frame_01.json").read_text())["frame"] == {"size": [511.0, 511.0]}
    with pytest.raises(ValueError, match="not both"):
        trimorph.FrameSequence(demo / "scene.json", frames, lms, tmp_path / "x", size=(511, 511))
    with pytest.raises(ValueError, match="size"):
        trimorph.FrameSequence(None, frames, lms, tmp_path / "x")


def test_missing_inputs_are_file_not_found(demo, tmp_path):
    """Issue 55: a missing folder raised ValueError; missing inputs are FileNotFoundError."""
    frames, lms, scene = demo / "frames4", demo / "landmarks", demo / "scene.json"
    with pytest.raises(FileNotFoundError, match="frames .*nowhere"):
        trimorph.FrameSequence(scene, tmp_path / "nowhere", lms, tmp_path / "out")
    with pytest.raises(FileNotFoundError, match="landmarks"):
        fit_frames(scene, frames, tmp_path / "none.csv", tmp_path / "out")
    with pytest.raises(FileNotFoundError, match="scene"):
        trimorph.FrameSequence(tmp_path / "none.json", frames, lms, tmp_path / "out")
    # Checked before the other arguments: with neither scene nor size, a missing folder
    # raised the ValueError about the scene.
    with pytest.raises(FileNotFoundError, match="frames .*nowhere"):
        fit_frames(None, tmp_path / "nowhere", lms, tmp_path / "out")
    with pytest.raises(FileNotFoundError, match="landmarks"):
        trimorph.FrameSequence(scene, frames, tmp_path / "none.csv", tmp_path / "out", size=(9, 9))
    assert not (tmp_path / "out").exists()
