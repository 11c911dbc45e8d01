"""The ``spark`` part-geometry and ``http`` open-state backends, against real local stand-ins.

``spark``: a Python program written here plays SPARK's public pipeline (reads the coarse-URDF JSON and the
input image from its arguments, writes ``mobility.urdf`` with one GLB per link, each GLB a scene of two
geometries placed by node transforms, at another scale and position); ``run_ours`` and ``spark-bench
eval`` run it, and each way it can fail gives a one-line error naming the file. ``http``: a real HTTP
server on loopback speaks the OpenAI-style images API. Also: an object whose ``base`` link carries the
body mesh (the procedural cabinet) goes through ``ours``.
"""

from __future__ import annotations

import base64
import io
import json
import re
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from helpers_http import LoopbackServer
from PIL import Image
from scipy.spatial import cKDTree

from spark_bench.data.case import BenchmarkCase
from spark_bench.errors import InputError
from spark_bench.methods.base import CaseInput
from spark_bench.methods.ours import OursMethod, ours_case
from spark_bench.spark import SparkConfig, run_ours
from spark_bench.spark.config import OpenStateConfig
from spark_bench.spark.geometry import spark_geometry
from spark_bench.spark.open_state import http_open_state
from spark_bench.spark.toy import write_toy_case

SUBSTITUTE = r'''"""A local stand-in for SPARK's public pipeline (``spark`` geometry backend), written by the tests.

It reads the coarse-URDF JSON (``--prior``) and the input image (``--image``), and writes what SPARK
writes: ``mobility.urdf`` with a ``base`` link, the PartNet-Mobility root joint, and one GLB per link.
Its "model" is the case's ground truth (``--case``): each part's rest mesh, moved to the object frame,
scaled by ``--scale`` and shifted by ``--shift`` (so the reader has to normalize it), split in two
geometries placed by GLB node transforms, one of them nested under a parent node. ``--mode`` makes it
fail in one of the ways the reader must report.
"""

import argparse
import json
import sys
import time
from pathlib import Path

ROOT_JOINT = '<joint name="joint_root" type="fixed"><origin xyz="0 0 0" rpy="1.570796 0 -1.570796"/>' \
             '<parent link="{world}"/><child link="{root}"/></joint>'


def rigid(seed: int):
    """A seeded rotation and translation (what a GLB node transform holds)."""
    import numpy as np
    import trimesh

    rng = np.random.default_rng(seed)
    angle, axis = rng.uniform(0.3, 2.5), rng.normal(size=3)
    matrix = trimesh.transformations.rotation_matrix(angle, axis / np.linalg.norm(axis))
    matrix[:3, 3] = rng.uniform(-2, 2, 3)
    return matrix


def glb_scene(vertices, faces, seed: int):
    """``(vertices, faces)`` as a scene of two geometries whose node transforms put them back in place."""
    import numpy as np
    import trimesh

    scene = trimesh.Scene()
    half = max(1, len(faces) // 2)
    first, second = faces[:half], faces[half:]
    outer, inner, single = rigid(seed), rigid(seed + 1), rigid(seed + 2)
    # the first half under a two-level node tree: world = outer @ inner @ stored
    local = trimesh.transform_points(vertices, np.linalg.inv(outer @ inner))
    scene.graph.update(frame_to="holder", frame_from=scene.graph.base_frame, matrix=outer)
    scene.add_geometry(trimesh.Trimesh(local, first, process=False), node_name="first", geom_name="first",
                       parent_node_name="holder", transform=inner)
    if len(second):
        local = trimesh.transform_points(vertices, np.linalg.inv(single))
        scene.add_geometry(trimesh.Trimesh(local, second, process=False), node_name="second",
                           geom_name="second", transform=single)
    return scene


def empty_glb() -> bytes:
    """A valid GLB whose scene has no mesh (trimesh refuses to export one)."""
    import struct

    text = json.dumps({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
                       "nodes": [{"name": "nothing"}]}).encode()
    text += b" " * (-len(text) % 4)
    return b"glTF" + struct.pack("<II", 2, 12 + 8 + len(text)) + struct.pack("<I4s", len(text), b"JSON") + text


def main() -> int:
    parser = argparse.ArgumentParser()
    for name in ("--image", "--prior", "--output", "--case"):
        parser.add_argument(name, required=True)
    parser.add_argument("--scale", type=float, default=0.5)
    parser.add_argument("--shift", type=float, nargs=3, default=[0.3, -0.2, 0.1])
    parser.add_argument("--mode", default="ok")
    args = parser.parse_args()
    out = Path(args.output)
    if args.mode == "fail":
        print("loading checkpoint...", flush=True)
        print("Traceback (most recent call last):\nRuntimeError: CUDA out of memory", file=sys.stderr)
        return 3
    if args.mode == "sleep":
        import subprocess

        subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])  # a child holding the pipes
        time.sleep(60)
    if args.mode == "nourdf":
        (out / "part_0.glb").write_bytes(b"")
        return 0
    import numpy as np  # only now: the failure modes above answer at once
    import trimesh
    from PIL import Image

    from spark_bench.data.case import BenchmarkCase
    from spark_bench.spark.geometry import part_meshes
    from spark_bench.spark.structure import CANONICAL_AXES, OBJECT_TO_WORLD

    with Image.open(args.image) as image:
        image_size = image.size
    prior = json.loads(Path(args.prior).read_text())
    names = [link["name"] for link in prior["links"]]
    parents = {j["child"]: j for j in prior["joints"]}
    geometry = part_meshes(BenchmarkCase(args.case).load_gt())
    shift = np.asarray(args.shift)
    position = {n: args.scale * np.asarray(parents[n]["origin"]) + shift if n in parents else np.zeros(3)
                for n in names}
    root = next(n for n in names if n not in parents)
    world = "base" if "base" not in names else "world"  # the prior may call the body "base"
    links, joints = [f'<link name="{world}"/>'], [ROOT_JOINT.format(world=world, root=root)]
    for k, name in enumerate(names):
        mesh = geometry.meshes.get(name)
        if mesh is None:
            links.append(f'<link name="{name}"/>')
            continue
        obj = trimesh.transform_points(mesh.vertices, np.block([[OBJECT_TO_WORLD.T, np.zeros((3, 1))],
                                                                 [np.zeros((1, 3)), np.ones((1, 1))]]))
        obj = args.scale * obj + shift
        glb = out / f"{name}.glb"
        glb.write_bytes(glb_scene(obj, np.asarray(mesh.faces), seed=10 * k).export(file_type="glb"))
        if args.mode == "broken_glb" and name == root:
            glb.write_bytes(b"glTF" + bytes(40))
        if args.mode == "missing_glb" and name != root:
            glb.unlink()
        if args.mode == "empty_glb" and name != root:
            glb.write_bytes(empty_glb())
        xyz = " ".join(f"{v:.9g}" for v in -position[name])  # link frame at the pivot, mesh in object frame
        links.append(f'<link name="{name}"><visual><origin xyz="{xyz}"/><geometry><mesh filename="{glb.name}"/>'
                     f'</geometry></visual></link>')
    for joint in prior["joints"]:
        xyz = " ".join(f"{v:.9g}" for v in position[joint["child"]] - position[joint["parent"]])
        axis = " ".join(str(v) for v in CANONICAL_AXES[joint["axis"]])
        limit = f'<limit lower="0" upper="{joint.get("upper") or 1.0}" effort="10" velocity="1"/>'
        joints.append(f'<joint name="{joint["name"]}" type="{joint["type"]}"><origin xyz="{xyz}"/>'
                      f'<parent link="{joint["parent"]}"/><child link="{joint["child"]}"/><axis xyz="{axis}"/>'
                      f'{limit if joint["type"] != "fixed" else ""}</joint>')
    (out / "mobility.urdf").write_text('<?xml version="1.0"?>\n<robot name="spark">\n' + "\n".join(links + joints)
                                       + "\n</robot>\n")
    (out / "received.json").write_text(json.dumps({"image_size": image_size, "links": names, "argv": sys.argv}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
'''

#: A small joint optimization (continuous fit only, low resolution): these tests check the plumbing.
TINY_OPT = ["optimize.refine=none", "optimize.screen_size=16", "optimize.short_steps=2",
            "optimize.short_fine_size=32", "optimize.short_fine_steps=2", "optimize.top_k=1",
            "optimize.score_size=32", "optimize.screen_score_size=16", "optimize.final_sizes=[32]",
            "optimize.final_taus=[0.7]", "optimize.final_steps=[6]", "optimize.max_faces=200",
            "optimize.sweeps=1"]
EXACT_PRIOR = ["prior.noise.p_axis=0", "prior.noise.p_type=0", "prior.noise.p_sign=0",
               "prior.noise.sigma_origin=0", "prior.noise.p_range=0"]


@pytest.fixture(scope="module")
def toy_case(tmp_path_factory) -> Path:
    case = tmp_path_factory.mktemp("toy") / "case"
    write_toy_case(case)
    return case


@pytest.fixture(scope="module")
def substitute(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("spark") / "spark_substitute.py"
    path.write_text(SUBSTITUTE)
    return path


def spark_command(script: Path, mode: str = "ok") -> str:
    return (f"{sys.executable} {script} --image {{image}} --prior {{prior}} --output {{out}} --case {{case}} "
            f"--mode {mode}")


def _prior_json(folder: Path, case: Path) -> Path:
    from spark_bench.spark.prior import ground_truth_structure

    path = folder / "prior.json"
    path.write_text(json.dumps(ground_truth_structure(BenchmarkCase(case).load_gt()).to_dict()))
    return path


def _spark_case(case: Path) -> CaseInput:
    """The case as a ``spark`` command given ``{case}`` sees it: its image, and the folder (the gt)."""
    return CaseInput(BenchmarkCase(case), frozenset({"image", "gt"}))


def _surface_gap(a, b) -> float:
    """Largest distance from a vertex of either mesh to the other's vertices."""
    return max(float(cKDTree(b.vertices).query(a.vertices)[0].max()),
               float(cKDTree(a.vertices).query(b.vertices)[0].max()))


# ----- spark geometry ----------------------------------------------------------------------------

def test_run_ours_with_spark_geometry_reads_glb_scenes(toy_case, substitute, tmp_path):
    from spark_bench.asset.ops import normalize_asset
    from spark_bench.data import load_object

    config = SparkConfig().with_overrides(["geometry.backend=spark", "optimize.enabled=false", *EXACT_PRIOR,
                                           f"geometry.spark_command={json.dumps(spark_command(substitute))}"])
    report = run_ours(ours_case(toy_case, config), tmp_path / "out", config)
    assert report["label"].startswith("prior=annotation,geometry=spark,open=dataset,opt=none,settings=")
    assert report["backends"]["geometry"] == "spark" and report["geometry_is_ground_truth"] is False
    received = json.loads((tmp_path / "out" / "spark_geometry" / "received.json").read_text())
    assert received["image_size"] == [256, 256] and received["links"] == ["body", "door", "drawer"]
    assert Path(received["argv"][received["argv"].index("--prior") + 1]) == (tmp_path / "out" / "prior.json")
    # every link's GLB (two geometries, nested node transforms, scale 0.5, shifted) lands where the
    # ground truth's part is, once both are in the benchmark frame
    truth = normalize_asset(BenchmarkCase(toy_case).load_gt())[0].link_meshes()
    ours = load_object(tmp_path / "out").link_meshes()
    assert sorted(ours) == ["body", "door", "drawer"]
    for name, mesh in ours.items():
        assert len(mesh.faces) == len(truth[name].faces)
        assert _surface_gap(mesh, truth[name]) < 1e-5, name
    assert report["diagnostics"]["prior"]["axis_err"] == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize(("mode", "file_name", "words"), [
    ("fail", "python", ["exited 3", "CUDA out of memory"]),
    ("nourdf", "mobility.urdf", ["wrote no mobility.urdf"]),
    ("missing_glb", "mobility.urdf", ["door.glb", "not found"]),
    ("broken_glb", "body.glb", ["cannot read mesh"]),
    ("empty_glb", "door.glb", ["link 'door'"]),  # the loader or the reader: both name the link and the file
])
def test_spark_command_failures_name_the_file(toy_case, substitute, tmp_path, mode, file_name, words):
    prior = _prior_json(tmp_path, toy_case)
    with pytest.raises(InputError) as info:
        spark_geometry(spark_command(substitute, mode), _spark_case(toy_case), prior, tmp_path / "work", timeout_s=60)
    message = str(info.value)
    assert "\n" not in message and file_name in message  # in the path, or in the problem for a mesh file
    for word in words:
        assert word in message


def test_spark_command_timeout_kills_its_children(toy_case, substitute, tmp_path):
    prior = _prior_json(tmp_path, toy_case)
    start = time.monotonic()
    with pytest.raises(InputError, match="timed out after 3 s"):
        spark_geometry(spark_command(substitute, "sleep"), _spark_case(toy_case), prior, tmp_path / "work",
                       timeout_s=3)
    assert time.monotonic() - start < 30  # the child holding the pipes was killed with it (it sleeps 60 s)


def test_spark_command_stale_output_and_bad_templates(toy_case, substitute, tmp_path):
    prior = _prior_json(tmp_path, toy_case)
    case = _spark_case(toy_case)
    geometry = spark_geometry(spark_command(substitute), case, prior, tmp_path / "work", timeout_s=60)
    assert sorted(geometry.meshes) == ["body", "door", "drawer"] and geometry.root == "body"
    extent = np.ptp(np.concatenate([m.vertices for m in geometry.meshes.values()]), axis=0)
    assert extent.max() == pytest.approx(2.0, abs=1e-6)  # normalized, although written at half scale
    # a second run that writes nothing must not pass off the first run's files as its own
    with pytest.raises(InputError, match="wrote no mobility.urdf"):
        spark_geometry(spark_command(substitute, "nourdf"), case, prior, tmp_path / "work", timeout_s=60)
    with pytest.raises(InputError, match="not a valid template"):
        spark_geometry("run --out {output}", case, prior, tmp_path / "work")
    with pytest.raises(InputError, match="cannot start"):
        spark_geometry("/nonexistent/spark-infer {image}", case, prior, tmp_path / "work")
    # the case folder holds the ground truth: a case without the gt input is not handed over
    with pytest.raises(PermissionError, match="'gt'"):
        spark_geometry(spark_command(substitute), CaseInput(BenchmarkCase(toy_case), frozenset({"image"})), prior,
                       tmp_path / "work")


def test_a_spark_command_given_the_case_folder_says_so_in_the_regime(substitute):
    base = ["geometry.backend=spark", "prior.backend=file", "prior.file_dir=\"/x\"", "optimize.enabled=false"]
    with_case = OursMethod(SparkConfig().with_overrides(
        [*base, f"geometry.spark_command={json.dumps(spark_command(substitute))}"]))
    assert with_case.inputs == ("image", "gt") and with_case.regime == "image + gt case folder (SPARK command)"
    without = OursMethod(SparkConfig().with_overrides(
        [*base, 'geometry.spark_command="spark-infer --image {image} --out {out} --note {{case}}"']))
    assert without.inputs == ("image",) and without.regime == "image"


# ----- objects whose base link carries the body --------------------------------------------------

def test_ours_on_an_object_whose_base_link_has_the_body(tmp_path):
    from spark_bench.asset.ops import normalize_asset
    from spark_bench.envs.cabinet import procedural_cabinet
    from spark_bench.spark.assemble import assemble_asset, joint_summary
    from spark_bench.spark.geometry import annotation_geometry, load_predicted_object
    from spark_bench.spark.prior import ground_truth_structure

    gt = normalize_asset(procedural_cabinet(seed=1))[0]
    assert gt.root == "base" and gt.links["base"].has_geometry
    geometry = annotation_geometry(gt)
    prior = ground_truth_structure(gt)
    assert prior.root == "base"
    asset = assemble_asset(prior, geometry)
    assert asset.root == "world" and asset.links["base"].has_geometry and not asset.links["world"].has_geometry
    assert asset.joints["joint_0"].parent == "base"
    # reports describe the object's joints, never the root joint that hangs it from the world
    assert [j["name"] for j in joint_summary(asset)] == ["joint_0", "joint_1"]
    assert [j["name"] for j in joint_summary(gt)] == ["joint_0", "joint_1"]
    for name, mesh in asset.link_meshes().items():  # the same rest geometry as the object's own
        assert _surface_gap(mesh, gt.link_meshes()[name]) < 1e-9
    # a prediction in that layout, with a prior that calls the body something else, also assembles
    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.spark.structure import PriorJoint, PriorLink, PriorStructure

    write_object_folder(gt, tmp_path / "pred")
    predicted = load_predicted_object(tmp_path / "pred")
    assert predicted.root == "base"
    renamed = PriorStructure([PriorLink("body", "body"), *prior.links[1:]],
                             [PriorJoint(**{**j.__dict__, "parent": "body"}) for j in prior.joints])
    asset = assemble_asset(renamed, predicted)
    assert asset.root == "base" and asset.links["body"].has_geometry
    assert _surface_gap(asset.link_meshes()["body"], gt.link_meshes()["base"]) < 1e-6


# ----- http open state ---------------------------------------------------------------------------

class FakeImages(LoopbackServer):
    """An OpenAI-style images endpoint on loopback: answers a scripted list of (status, body, delay)."""

    def __init__(self, script):
        super().__init__(script, lambda body, entry: entry)

    @property
    def url(self):
        return f"{self.root}/v1/images/edits"


def images_answer(png: bytes) -> bytes:
    return json.dumps({"created": 0, "data": [{"b64_json": base64.b64encode(png).decode()}]}).encode()


def _png(image: Image.Image) -> bytes:
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def _open_config(url, **kw):
    return OpenStateConfig(backend="http", url=url, model="test-image", api_key_env="SPARK_TEST_KEY", **kw)


def test_http_open_state_request_and_mask(toy_case, monkeypatch):
    monkeypatch.setenv("SPARK_TEST_KEY", "sekrit")
    input_png = (toy_case / "input.png").read_bytes()
    open_image = Image.open(toy_case / "open.png")
    truth = np.asarray(Image.open(toy_case / "open_seg.png")) > 0
    bigger = open_image.resize((512, 512), Image.Resampling.NEAREST)  # generators answer at their own size
    script = [(200, images_answer(_png(open_image)), 0), (200, images_answer(_png(bigger)), 0)]
    with FakeImages(script) as server:
        same = http_open_state(_open_config(server.url), input_png)
        resized = http_open_state(_open_config(server.url), input_png)
    request = server.requests[0]
    assert request["path"] == "/v1/images/edits" and request["auth"] == "Bearer sekrit"
    assert request["body"]["model"] == "test-image" and request["body"]["response_format"] == "b64_json"
    assert request["body"]["image"] == "data:image/png;base64," + base64.b64encode(input_png).decode()
    assert "open" in request["body"]["prompt"]
    assert same.source == server.url and same.mask.shape == (256, 256)
    assert np.array_equal(same.mask > 0.5, truth)
    assert resized.mask.shape == (256, 256)  # brought to the camera's size
    iou = np.logical_and(resized.mask > 0.5, truth).sum() / np.logical_or(resized.mask > 0.5, truth).sum()
    assert iou > 0.97


@pytest.mark.parametrize(("reply", "words"), [
    ((500, b'{"error": "overloaded"}', 0), ["HTTP 500", "overloaded"]),
    ((200, b"<html>not json", 0), ["not JSON"]),
    ((200, b'{"data": [{"url": "https://x/y.png"}]}', 0), ["no data[0].b64_json"]),
    ((200, images_answer(b"this is not a PNG"), 0), ["not an image", "17 bytes"]),
    ((200, json.dumps({"data": [{"b64_json": "@@@"}]}).encode(), 0), ["not base64"]),
    ((200, images_answer(_png(Image.new("RGB", (64, 64), "white"))), 0), ["no object"]),
    ((200, images_answer(b""), 2.0), ["no answer within 0.5 s"]),
])
def test_http_open_state_failures(reply, words):
    with FakeImages([reply]) as server:
        with pytest.raises(InputError) as info:
            http_open_state(_open_config(server.url, timeout_s=0.5, max_retries=0), _png(Image.new("RGB", (64, 64))))
    message = str(info.value)
    assert info.value.path == server.url and "\n" not in message
    for word in words:
        assert word in message
    assert len(server.requests) == 1


def test_http_open_state_retries_overload_and_gives_up_on_a_bad_request(toy_case):
    good = images_answer(_png(Image.open(toy_case / "open.png")))
    input_png = (toy_case / "input.png").read_bytes()
    config = _open_config("", max_retries=2, backoff_s=0.0)
    with FakeImages([(503, b'{"error": "busy"}', 0), (429, b"{}", 0), (200, good, 0)]) as server:
        state = http_open_state(replace(config, url=server.url), input_png)
    assert len(server.requests) == 3 and state.mask.max() == 1.0
    with FakeImages([(503, b'{"error": "busy"}', 0)]) as server:
        with pytest.raises(InputError, match="failed after 3 attempts: HTTP 503: .*busy"):
            http_open_state(replace(config, url=server.url), input_png)
    assert len(server.requests) == 3
    with FakeImages([(400, b'{"error": "bad prompt"}', 0), (200, good, 0)]) as server:
        with pytest.raises(InputError, match="HTTP 400: .*bad prompt"):
            http_open_state(replace(config, url=server.url), input_png)
    assert len(server.requests) == 1  # a 4xx is the request's fault: not tried again


# ----- spark-bench eval --method ours --config X --------------------------------------------------

def _eval(bench: Path, config: Path, capsys, home: Path) -> dict:
    from spark_bench.cli import main

    code = main(["eval", "--method", "ours", "--config", str(config), "--bench", str(bench), "--no-sim",
                 "--n-samples", "3000", "--json", "--no-progress", "--workers", "0"])
    out = capsys.readouterr()
    assert code == 0, out.err
    doc = json.loads(out.out)
    failed = [(r["case_id"], r["stage"], r["reason"]) for r in _rows(home) if r["status"] != "ok"]
    assert doc["n_failed"] == 0, failed
    return doc


def _rows(home: Path) -> list[dict]:
    from spark_bench.evaluation.store import ResultsStore

    with ResultsStore(home / "results.sqlite") as store:
        return store.rows()


def _config_file(path: Path, overrides: list[str]) -> Path:
    path.write_text(json.dumps(SparkConfig().with_overrides(overrides).to_dict()))
    return path


def test_eval_ours_with_spark_geometry(substitute, tmp_path, capsys, isolated_home):
    from helpers_bench import make_tiny_bench

    bench = make_tiny_bench(tmp_path, n=1)  # procedural cabinets: their base link carries the body
    config = _config_file(tmp_path / "ours.json", [
        "geometry.backend=spark", f"geometry.spark_command={json.dumps(spark_command(substitute))}",
        *EXACT_PRIOR, *TINY_OPT])
    doc = _eval(bench, config, capsys, isolated_home)
    assert doc["n_failed"] == 0 and doc["method"].startswith("ours (prior=annotation,geometry=spark,open=dataset,opt=fit-only,settings=")
    # SPARK's stand-in returns the true parts: the shape metrics are real (not n/a) and as good as 3000
    # surface samples can tell (their own noise floor is a CD of about 0.1 on this object)
    assert doc["metrics"]["cd"] < 0.15 and doc["metrics"]["fscore@0.1"] > 0.95
    assert doc["metrics"]["type_err"] == 0.0 and doc["metrics"]["axis_err"] < 1e-3
    rows = _rows(isolated_home)
    assert all(r["metrics"]["part_fscore@0.1"] == 1.0 for r in rows)
    assert sorted(r["variant"] for r in rows) == ["", "w/o joint opt."]
    for row in rows:
        assert row["shape_metrics_valid"] and row["info"]["backends"] == {
            "prior": "annotation", "geometry": "spark", "open_state": "dataset", "optimize": "none"}
        assert row["config"]["method_config"]["geometry"]["spark_command"] == spark_command(substitute)


def test_eval_ours_with_http_open_state(tmp_path, capsys, isolated_home):
    from helpers_bench import make_tiny_bench

    bench = make_tiny_bench(tmp_path, n=1)
    case = bench / "cases" / "cab0"
    with FakeImages([(200, images_answer((case / "open.png").read_bytes()), 0)]) as server:
        config = _config_file(tmp_path / "ours.json", [
            "open_state.backend=http", f"open_state.url={json.dumps(server.url)}", "open_state.model=img",
            "open_state.timeout_s=30", *TINY_OPT])
        doc = _eval(bench, config, capsys, isolated_home)
    assert doc["n_failed"] == 0 and "open=http" in doc["method"]
    assert len(server.requests) == 1
    sent = server.requests[0]["body"]["image"].split(",", 1)[1]
    assert base64.b64decode(sent) == (case / "input.png").read_bytes()
    rows = _rows(isolated_home)
    row = next(r for r in rows if r["variant"] == "")
    assert row["info"]["backends"]["open_state"] == "http" and "open=http:img,opt=fit-only" in row["info"]["label"]
    assert not row["shape_metrics_valid"]  # annotation geometry: shape metrics are n/a
    run_dir = Path(row["prediction_dir"])
    report = json.loads((run_dir / "spark_report.json").read_text())
    assert report["open_state_source"] == server.url
    assert report["loss_refined"] <= report["loss_prior"]


def test_run_ours_with_every_external_backend(toy_case, substitute, tmp_path):
    """VLM prior, SPARK geometry and generated open state together, each a real local process/server."""
    from test_spark_vlm import GOOD, FakeVLM

    open_png = (toy_case / "open.png").read_bytes()
    with FakeVLM([(200, json.dumps(GOOD))]) as vlm, FakeImages([(200, images_answer(open_png), 0)]) as images:
        config = SparkConfig().with_overrides([
            "prior.backend=vlm", f"vlm.base_url={json.dumps(vlm.base_url)}", "vlm.backoff_s=0",
            "geometry.backend=spark", f"geometry.spark_command={json.dumps(spark_command(substitute))}",
            "open_state.backend=http", f"open_state.url={json.dumps(images.url)}", *TINY_OPT])
        report = run_ours(ours_case(toy_case, config), tmp_path / "out", config)
    assert re.fullmatch(r"prior=vlm:[\w.-]+,geometry=spark,open=http,opt=fit-only,settings=[0-9a-f]{8}", report["label"])
    assert report["backends"] == {"prior": "vlm", "geometry": "spark", "open_state": "http", "optimize": "none"}
    # the VLM's answer went to SPARK as its prior, and SPARK's links are the VLM's
    assert json.loads((tmp_path / "out" / "prior.json").read_text()) == GOOD
    received = json.loads((tmp_path / "out" / "spark_geometry" / "received.json").read_text())
    assert received["links"] == ["body", "door", "drawer"]
    assert report["open_state_source"] == images.url and report["loss_refined"] <= report["loss_prior"]
    assert "diagnostics" not in report  # nothing read the ground truth
