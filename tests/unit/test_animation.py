"""Animations: the tip drawn in every frame is where results.csv says (within a pixel), the
magnification is stated, MP4 works, bad input leaves no file behind."""

from __future__ import annotations

import tomllib
from pathlib import Path

import imageio.v3 as iio
import imageio_ffmpeg
import numpy as np
import pytest

import flexlink
from flexlink.cli import main
from flexlink.results import read_run
from flexlink.results.animation import TIP_COLOURS, animate
from flexlink.results.arm_tracks import AnimationInputError
from flexlink.results.reading import read_csv_run
from flexlink.results.writers import CHANNELS_CSV, RESULTS_CSV, write_run
from flexlink.scenario import paper_experiment_path, resolve_scenario_dict, scenario_from_dict


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    raw = tomllib.loads(paper_experiment_path().read_text())
    raw["simulation"].update(t_end=2.0)
    results = flexlink.simulate(scenario_from_dict(raw))
    return write_run(results, tmp_path_factory.mktemp("anim") / "run",
                     resolve_scenario_dict(raw), figures=False)


def _dot_centre(frame: np.ndarray, colour: str) -> tuple[float, float]:
    """Centre (column, row; pixel (i, j) spans [i, i+1)) of the pixels of one colour."""
    rgb = np.array([int(colour[i:i + 2], 16) for i in (1, 3, 5)])
    rows, cols = np.nonzero(np.abs(frame[:, :, :3].astype(int) - rgb).sum(axis=-1) < 30)
    assert rows.size > 10, f"no tip dot of colour {colour}"
    return cols.mean() + 0.5, rows.mean() + 0.5


def test_the_drawn_tips_follow_results_csv_within_a_pixel(paper_run: Path,
                                                          tmp_path: Path) -> None:
    results = read_run(paper_run)
    info = animate(results, tmp_path / "arm.gif", fps=10)
    frames = iio.imread(tmp_path / "arm.gif", index=None)
    assert frames.shape[0] == info.times.size == 21
    assert frames.shape[1:3] == (info.size[1], info.size[0])
    csv = read_csv_run(paper_run / RESULTS_CSV, paper_run / CHANNELS_CSV)
    for frame, index in zip(frames, info.indices, strict=True):
        for link, colour in zip(("link1", "link2"), TIP_COLOURS, strict=False):
            col, row = info.to_pixel(csv[f"{link}_tip_X"][index], csv[f"{link}_tip_Y"][index])
            found = _dot_centre(frame, colour)
            assert abs(found[0] - col) <= 1.0 and abs(found[1] - row) <= 1.0, (index, link)


def test_magnified_animation_states_it_and_mp4_is_written(paper_run: Path,
                                                          tmp_path: Path) -> None:
    results = read_run(paper_run)
    info = animate(results, tmp_path / "arm.mp4", magnification=10.0, speed=0.5, fps=10,
                   channels=["pzt"])
    assert info.times.size == 41 and info.magnification == 10.0
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "arm.mp4"))
    assert frames == 41 and seconds == pytest.approx(4.1, abs=0.11)
    assert results.animate(tmp_path / "same.gif", fps=5) == tmp_path / "same.gif"


def test_cli_animate_writes_into_the_run_folder(paper_run: Path, capsys) -> None:
    assert main(["animate", str(paper_run), "--fps", "5", "--channels", "pzt"]) == 0
    assert (paper_run / "animation.gif").stat().st_size > 1000
    assert "animation.gif" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["--channels", "nope"], "missing channel(s): nope"),
    (["--magnify", "-2"], "magnification must be a positive number"),
    (["-o", "{out}/a.avi"], "unknown format 'avi'"),
])
def test_bad_options_name_the_problem_and_write_nothing(paper_run: Path, tmp_path: Path,
                                                        capsys, argv, message) -> None:
    argv = [a.format(out=tmp_path) for a in argv]
    out = ["-o", str(tmp_path / "a.gif")] if "-o" not in argv else []
    assert main(["animate", str(paper_run), *argv, *out]) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_not_a_run_folder_and_an_unknown_option(tmp_path: Path, capsys) -> None:
    (tmp_path / "notes.txt").write_text("hello")
    assert main(["animate", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "is not a flexlink run folder" in err and str(tmp_path) in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]
    with pytest.raises(SystemExit) as exc:
        main(["animate", str(tmp_path), "--colour", "red"])
    assert exc.value.code == 2
    assert "unrecognized arguments: --colour red" in capsys.readouterr().err


def test_results_without_shapes_are_refused(paper_run: Path, tmp_path: Path) -> None:
    results = read_csv_run(paper_run / RESULTS_CSV, paper_run / CHANNELS_CSV)
    with pytest.raises(AnimationInputError, match="no link shapes"):
        animate(results, tmp_path / "a.gif")
    assert list(tmp_path.iterdir()) == []
