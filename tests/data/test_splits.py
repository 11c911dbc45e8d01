"""The field's named test splits (``spark_bench.data.splits``): each is a listed benchmark whose ids are
unique PartNet-Mobility ids with their source, prepared from a download that holds one of them (a shared
real object under a listed id) with the camera its method states, the others listed as missing."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from helpers_real import PARTNET_DEV, REAL_IDS, real_object_path

from spark_bench.cli import main
from spark_bench.data.benchmarks import BENCHMARKS, ensure_benchmark
from spark_bench.data.camera import CameraView, spherical_position
from spark_bench.data.case import Benchmark
from spark_bench.data.prepare import PrepareOptions
from spark_bench.data.splits import (
    CAGE_TEST_IDS,
    FREEART3D_TEST_IDS,
    PHYSX_ANYTHING_TEST_IDS,
    SINGAPO_TEST_IDS,
    SPLITS,
    View,
)
from spark_bench.errors import SparkBenchError

FAST = ["--image-size", "64", "--resolution", "24"]
#: a small shared object (a bottle, 192 KB) copied under a listed id where no shared object has one
STAND_IN = "3763"
#: an id no split lists: a folder under it must be ignored
UNLISTED = "99999"
SOURCE = re.compile(r"[\w.-]+/[\w.-]+:[\w./-]+@[0-9a-f]{40}")


def shared_object_for(ids: tuple[str, ...]) -> tuple[str, Path]:
    """``(listed id, folder to copy)``: a shared real object that is itself in ``ids`` (real_objects first,
    then partnet_dev), else the stand-in under the first listed id; skips where ``../shared`` is absent."""
    for object_id in ids:
        if object_id in REAL_IDS:
            return object_id, real_object_path(object_id)
    for object_id in ids:
        if (PARTNET_DEV / object_id / "mobility.urdf").is_file():
            return object_id, PARTNET_DEV / object_id
    return ids[0], real_object_path(STAND_IN)


def fake_download(src: Path, ids: tuple[str, ...]) -> str:
    """A PartNet-Mobility folder holding one object under a listed id and one under an unlisted id."""
    present, folder = shared_object_for(ids)
    shutil.copytree(folder, src / present)
    shutil.copytree(folder, src / UNLISTED)
    return present


# ----- the lists ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(SPLITS))
def test_each_split_is_unique_ids_with_its_source(name):
    split, spec = SPLITS[name], BENCHMARKS[name]
    assert split.ids and all(re.fullmatch(r"[1-9][0-9]*", i) for i in split.ids)
    assert len(set(split.ids)) == len(split.ids)
    assert UNLISTED not in split.ids
    assert SOURCE.fullmatch(split.source), split.source
    assert split.method and split.read and split.camera
    # the benchmark is the split, with its camera
    assert spec.is_listed and spec.ids == split.ids and spec.n_objects == len(split.ids)
    assert spec.source == split.source
    assert (spec.options.fov_deg, spec.options.distance) == (split.view.fov_deg, split.view.distance)
    assert (spec.options.azimuth_deg, spec.options.elevation_deg) == (split.view.azimuth_deg,
                                                                      split.view.elevation_deg)


def test_the_splits_as_their_files_hold_them():
    counts = {name: len(split.ids) for name, split in SPLITS.items()}
    assert counts == {"spark-test": 42, "singapo-test": 77, "cage-test": 81, "freeart3d-test": 144,
                      "physx-anything-test": 388, "real2code-test": 42}
    # first and last of each file, as read (SINGAPO's "Table/23807" ... "Oven/7179")
    assert (SINGAPO_TEST_IDS[0], SINGAPO_TEST_IDS[-1]) == ("23807", "7179")
    assert (CAGE_TEST_IDS[0], CAGE_TEST_IDS[-1]) == ("25959", "12252")
    assert (FREEART3D_TEST_IDS[0], FREEART3D_TEST_IDS[-1]) == ("100214", "103508")
    assert (PHYSX_ANYTHING_TEST_IDS[0], PHYSX_ANYTHING_TEST_IDS[-1]) == ("103189", "103361")
    # FreeArt3D's 12 Display ids are only in its "revolute" list, never read by its scripts: left out
    assert not {"5088", "4574", "4094", "5306", "3393", "4529"} & set(FREEART3D_TEST_IDS)
    # what the cage-test note says of SINGAPO's split against CAGE's
    assert set(CAGE_TEST_IDS) - set(SINGAPO_TEST_IDS) == {"25959", "33914", "102309", "102311", "101594",
                                                          "102318", "102380", "12578", "11231"}
    assert set(SINGAPO_TEST_IDS) - set(CAGE_TEST_IDS) == {"31249", "27619", "7320", "7130", "7179"}


def test_freeart3d_camera_is_its_run_rendering_view():
    """2.1 x the longest side (2) away horizontally, sin(45 deg) x that higher, pi/8 past the front."""
    view = SPLITS["freeart3d-test"].view
    position = spherical_position(view.azimuth_deg, view.elevation_deg, view.distance)
    assert float((position[0] ** 2 + position[1] ** 2) ** 0.5) == pytest.approx(4.2, abs=1e-3)
    assert float(position[2]) == pytest.approx(4.2 * 0.5 ** 0.5, abs=1e-3)
    # in front (-X) and to its -Y side: Blender's +X is the mesh's +X, the world's -Y
    assert position[0] < 0 and position[1] < 0
    assert float(position[1] / position[0]) == pytest.approx(0.41421, abs=1e-4)  # tan(pi/8)
    assert view.fov_deg == 45.0


def test_a_view_maps_onto_prepare_options():
    seeded = BENCHMARKS["cage-test"].options
    assert seeded.to_json() == PrepareOptions().to_json()  # CAGE states no camera: the default view
    assert View() == SPLITS["physx-anything-test"].view
    assert BENCHMARKS["singapo-test"].options.distance == pytest.approx(3.25 * 2 / 1.5, abs=0.05)


# ----- preparing a split -------------------------------------------------------------------------------
@pytest.mark.real
@pytest.mark.parametrize("name", list(SPLITS))
def test_each_split_prepares_the_ids_present_and_lists_the_rest(name, tmp_path, capsys):
    split = SPLITS[name]
    src = tmp_path / "download"
    present = fake_download(src, split.ids)
    out = tmp_path / name
    assert main(["data", "prepare", "--src", str(src), "--bench", name, "--out", str(out), *FAST]) == 0
    text = capsys.readouterr().out
    n = len(split.ids)
    expected_missing = [i for i in split.ids if i != present]
    assert f"{name}: 1 of {n} listed objects found in {src}, 1 prepared into {out}, 0 failed" in text
    assert f"missing ({n - 1}): {' '.join(expected_missing[:3])} " in text
    manifest = Benchmark(out).manifest()
    assert manifest["name"] == name and list(manifest["cases"]) == [present]  # the unlisted folder skipped
    assert manifest["missing"] == expected_missing and manifest["listed"] == list(split.ids)
    assert manifest["source"] == split.source
    view = CameraView.load(Benchmark(out).case(present).camera_path)
    assert view.width == 64 and view.fov_deg == pytest.approx(split.view.fov_deg)
    assert view.distance == pytest.approx(split.view.distance)
    if split.view.azimuth_deg is not None:
        assert (view.azimuth_deg, view.elevation_deg) == (split.view.azimuth_deg, split.view.elevation_deg)
    else:  # the seeded front view: within 60 degrees of the front, 10 to 40 degrees up
        assert abs(view.azimuth_deg - 180.0) <= 60.0 and 10.0 <= view.elevation_deg <= 40.0


def test_data_prepare_help_lists_every_split(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "1000")  # one line per option: no name broken at a hyphen
    with pytest.raises(SystemExit) as exited:
        main(["data", "prepare", "--help"])
    assert exited.value.code == 0
    text = capsys.readouterr().out
    for name, split in SPLITS.items():
        assert f"{name}: {split.method}, {len(split.ids)} ids" in text


def test_an_unprepared_split_says_how_to_prepare_it(isolated_home):
    with pytest.raises(SparkBenchError, match="--bench physx-anything-test"):
        ensure_benchmark("physx-anything-test")
