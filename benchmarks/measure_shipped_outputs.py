"""Other methods' real shipped outputs (project issue #24, item 4): what each method's public repository ships,
whether spark-bench's importers read it, and its score where its object is one of the local objects.

Inputs, none of which is copied into the repository:

- ``--mirrors``: snapshots of the methods' repositories as git directories, ``<mirrors>/<owner>+<name>/repo``
  (the layout the search tool's ``fetch`` gives) or ``<mirrors>/<owner>+<name>`` itself; a repository that is
  absent is reported as such;
- ``--shared``: the local ground truth, ``partnet_dev/<id>/`` and ``real_objects/<id>/``.

What it does:

1. Inventory (:data:`SHIPPED`, :data:`NO_OUTPUT`): for each repository, the commit read and, for each shipped
   output, its files: present, or absent from the snapshot (a snapshot lacks files of 4 MiB and more).
2. The object of each output, from the output itself: a URDF's robot name ``partnet_<ShapeNet model id>``
   (PartNet-Mobility's own URDFs are named so) compared with each local object's ``meta.json`` ``model_id``;
   a PartNet-Mobility id in the output's path compared with the local ids.
3. Each output laid out as ``DIR/<case>/`` exactly as shipped (the output folder's files at their paths in that
   folder; a URDF's meshes at the paths it references) and read with the format's reader when spark-bench has
   it (:data:`spark_bench.formats.FORMATS`); otherwise listed as awaiting that reader.
4. Outputs whose object is local and which import: ``data prepare`` of only those objects (``--image-size
   256``), ``import``, ``eval --method predictions --align icp`` labelled ``<method> (shipped output)`` into a
   results store of their own, and the Markdown leaderboard.
5. The report (Markdown) on ``--out``.

Run (about a minute when nothing is local; fetch the repositories first)::

    nice -n 10 python -m benchmarks.measure_shipped_outputs --mirrors <mirrors> --shared ../shared \\
        --work /tmp/realout --out benchmarks/results/shipped_outputs.md
"""

from __future__ import annotations

import argparse
import json
import posixpath
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

#: File endings counted as meshes.
MESH_ENDINGS = (".glb", ".gltf", ".obj", ".ply", ".stl", ".dae")
#: SPARK's output folders have their own importer (``import spark``), not one of FORMATS.
SPARK = "spark"
#: A PartNet-Mobility URDF's robot name: ``partnet_<ShapeNet model id>``.
ROBOT_NAME = re.compile(r"^partnet_([0-9a-f]{32})$")


@dataclass(frozen=True)
class Run:
    """One shipped output, as one run folder.

    :param case: its name in the report (``DIR/<case>/``; a local object's id replaces it when scored)
    :param folder: the folder of the repository whose files make the run folder ("" for the root)
    :param files: only these files of ``folder`` (and, for a URDF, the meshes it references); empty: all
    :param id_in_path: a PartNet-Mobility id the output's path names (its object)
    """

    case: str
    folder: str
    files: tuple[str, ...] = ()
    id_in_path: str = ""


@dataclass(frozen=True)
class Shipped:
    """What one repository ships as real output of its method.

    :param method: the method
    :param repo: ``owner/name``
    :param path: the shipped output's path in the repository (for the inventory)
    :param what: what it is, and what produced it
    :param obj: the object it is of, and how that is known
    :param fmt: the spark-bench format that reads it (None: no format can: not an object file)
    :param runs: its run folders
    """

    method: str
    repo: str
    path: str
    what: str
    obj: str
    fmt: str | None
    runs: tuple[Run, ...] = ()


@dataclass(frozen=True)
class NoOutput:
    """A repository that ships no output of its method: what it ships instead.

    :param method: the method
    :param repo: ``owner/name``
    :param ships: what it ships (inputs, id lists...), with paths
    :param check: paths that must exist at the commit read (a check that the listing is of this snapshot)
    :param commit: the commit read through the search index when no snapshot can be fetched
    """

    method: str
    repo: str
    ships: str
    check: tuple[str, ...] = ()
    commit: str = ""


URDFORMER_LABELS = ("label3", "label4", "label13", "label29", "label31", "label40", "label42", "label53",
                    "label55", "label62")

SHIPPED: tuple[Shipped, ...] = (
    Shipped("DIPO", "RQ-Wu/DIPO", "results/{0,1,2}/object.json (+ vis_img.png)",
            "the quick demo's output (`demo_img.py` on `examples/1.png` + `1_open_{1,2}.png`; the README: "
            "'the output will be saved at ./results ... three objects ... with different noises'); the three "
            "object.json are byte-identical; the part-mesh retrieval calls of `demo_img.py` are commented out",
            "a product photo of a white two-drawer cabinet (`examples/1.png`), category StorageFurniture: "
            "not a PartNet-Mobility render, no id", "singapo",
            tuple(Run(f"dipo-results-{i}", f"results/{i}") for i in range(3))),
    Shipped("SPARK (its PartCrafter fork)", "YumengHe/PartCrafter", "outputs/test{1,2,3,4}/",
            "SPARK's URDFs (`mobility.urdf`; test1, test2: also `mobility_optimized.urdf`, the joint "
            "optimizer's) with PartCrafter part GLBs and renders; `test3/readme.md`: a sliding test",
            "PartNet-Mobility objects named by the robot name `partnet_<ShapeNet model id>` (test1 and test2 "
            "10798ccb…, test3 3a910cc1…, test4 109a1984…); compared with the local objects' meta.json "
            "model_id", "spark",
            tuple(Run(f"spark-fork-{t}", f"outputs/{t}") for t in ("test1", "test2", "test3", "test4"))),
    Shipped("URDFormer", "WEIRDLabUW/urdformer", "output/label*.urdf (10) and output.urdf",
            "URDFormer's predictions for `images/label*.png` (README: 'the urdf predictions by default will be "
            "saved under output'), built from the repository's template meshes (`meshes/`, referenced as "
            "`../meshes/...`)",
            "photos of real cabinets and kitchens (`images/label*.png`): not PartNet-Mobility, no id", "urdf",
            tuple(Run(f"urdformer-{label}", "", (f"output/{label}.urdf",)) for label in URDFORMER_LABELS)),
    Shipped("Articulate-Anything", "vlongle/articulate-anything",
            "datasets/multi_modal_incontext_examples/joint_actor/in_context_actor_examples_datasets/47645/joint_0/",
            "an in-context demonstration for the LLM (`link_placement.py`, `joint_pred.py` in the method's Python "
            "API; its comments read 'Groundtruth video analysis'), written for the prompt, not a run's output; "
            "likewise 100963, 103739, 12565, 41003 and the critic examples 48167, 48018, 38516, 40417, 39392, "
            "4590. `examples/articulate_partnet.ipynb` holds a real run's generated code and renders in its cell "
            "outputs, for PartNet-Mobility 35059 (not local)",
            "PartNet-Mobility 47645 (the folder name and `link_summary.txt` `object_id: 47645`): a local object "
            "(real_objects/47645, Box)", None,
            (Run("articulate-anything-47645", "datasets/multi_modal_incontext_examples/joint_actor/"
                 "in_context_actor_examples_datasets/47645/joint_0", id_in_path="47645"),)),
)

NO_OUTPUT: tuple[NoOutput, ...] = (
    NoOutput("SINGAPO", "3dlg-hcvc/singapo", "inputs only: `demo/demo_input.png`, `demo/example_graph.json` (a "
             "part graph without joints); `data/data_split.json` (ids); page images", ("demo/demo_input.png",)),
    NoOutput("CAGE", "3dlg-hcvc/cage", "input graphs only: `demo_graph.json`, `datamodules/ood_graphs.json`; "
             "`indexes/data_split.json` (ids)", ("demo_graph.json",)),
    NoOutput("FreeArt3D", "PeterZs/FreeArt3D", "inputs only: `examples/cabinet*/NN.png` + `NN_seg.png` (photos "
             "of three real cabinets, not PartNet-Mobility); `configs/partnet.json` (its evaluation ids, 16 of them "
             "local) but no `sds_output/` or `output.urdf`", ("examples/cabinet/00.png", "configs/partnet.json")),
    NoOutput("PhysX-Anything", "ziangcao0312/PhysX-Anything", "inputs only: `demo/0.png`..`16.png`; "
             "`evaluation_video/908.mp4` (a video); `testset.npy` (388 ids, 15 local); no `basic.urdf`/MJCF",
             ("demo/0.png", "testset.npy")),
    NoOutput("Real2Code", "MandiZhao/real2code", "code and a teaser image only", ("real2code-teaser.jpg",)),
    NoOutput("Articulate AnyMesh", "UMass-Embodied-AGI/ArticulateAnymesh", "inputs only: "
             "`data/fridge/mesh.glb`, `data/toaster/mesh.glb` (absent from the snapshot: 4 MiB or more) with "
             "their `configs/*.yaml`; no `mobility.json`", ("configs/fridge.yaml",)),
    NoOutput("PartCrafter", "wgsxm/PartCrafter", "inputs only: `assets/images*/` (Objaverse, ABO, 3D-Front "
             "images); `assets/objects/{sword,scissors}.glb` are training-data examples for its preprocessing "
             "scripts", ("assets/objects/sword.glb",)),
    NoOutput("Particulate", "RuiningLi/particulate", "inputs only: `hunyuan3d-examples/*.glb` (meshes made by "
             "Hunyuan3D for `infer.py`; absent from the snapshot: 4 MiB or more)", ("infer.py",)),
    NoOutput("OmniPart", "HKU-MMLab/OmniPart", "no snapshot here; the index's vendored copy "
             "(`V-Sekai-fire/livebook-nx` `thirdparty/OmniPart/assets/example_data/*.jpg`) and the fork "
             "`ericchen321/OmniPart` hold input images only", commit="no snapshot; index: livebook-nx d57e7c0"),
    NoOutput("SPARK", "mebam1/spark", "no snapshot here; the index lists inputs `image/45162.png`, "
             "`image copy/44817.png`, `image2/{35059,46893}.png` (PartNet-Mobility ids, none local), "
             "`articulate-anything-render/*.png` (PNG renders of Articulate-Anything results for 10090, 10101, 7221, 7236, "
             "8867, 8897, none local) and one GLB `assets/A_post.glb` (no URDF, no "
             "run folder)", commit="no snapshot; index: 9b114a9, 50afae5, f111bd6"),
)

#: What the tables cannot say, for whoever reads the report.
NOTES: tuple[str, ...] = (
    "A score needs a shipped output of one of the local objects. None of the shipped outputs above is: DIPO's and "
    "URDFormer's are of photos, the SPARK fork's of PartNet-Mobility objects that are not local (their ShapeNet "
    "model ids match no local `meta.json`). The methods' published evaluation ids do overlap the local objects "
    "(FreeArt3D `configs/partnet.json`: 16, PhysX-Anything `testset.npy`: 15), but they ship no outputs for them.",
    "The one local object named by a shipped file, Articulate-Anything's 47645, is an in-context demonstration "
    "(a program in the method's API, written for the prompt), not an output of a run; compiled, its geometry "
    "would be the ground truth's own meshes. It is not scored.",
    "DIPO's `results/*/object.json` hold the part boxes and joints only (no `plys`: the demo's retrieval step is "
    "commented out): the singapo reader checks the tree and the joints, then refuses at the meshes, as it "
    "should; no score can come from boxes.",
    "URDFormer's URDFs name their meshes `../meshes/...`: laid out as shipped, each run folder holds "
    "`output/labelN.urdf` and the `meshes/` files it names (the `urdf` reader takes the URDF nearest the top "
    "and keeps every mesh inside the run folder).",
    "The SPARK fork's `outputs/test*` are read by `import spark`'s reader (`spark_bench/formats/spark/`), which "
    "takes `mobility_optimized.urdf` where there is one (test1, test2) and applies no further rotation to these "
    "URDFs (they carry PartNet-Mobility's root joint). Each is refused at a part GLB the snapshot lacks (4 MiB "
    "or more; the public repository has it): with a full clone they would import, but their objects are not "
    "local, so they would still not be scored.",
    "No repository ships an MJCF output (PhysX-Anything, Real2Code and Particulate ship none): nothing here is "
    "for the `mjcf` reader.",
)


# ----- the repositories ----------------------------------------------------------------------------------------
@dataclass
class TreeFile:
    """One file of a repository at the commit read.

    :param path: its path in the repository
    :param sha: its blob
    :param present: whether the snapshot holds its content
    """

    path: str
    sha: str
    present: bool


def git(git_dir: Path, *args: str) -> bytes:
    """The output of ``git --git-dir GIT_DIR ARGS``.

    :param git_dir: the repository's git directory
    :param args: the git command
    """
    return subprocess.run(["git", "--git-dir", str(git_dir), *args], check=True, capture_output=True).stdout


def git_dir_of(mirrors: Path, repo: str) -> Path | None:
    """The git directory of ``repo`` under ``mirrors`` (None when absent).

    :param mirrors: the folder of snapshots
    :param repo: ``owner/name``
    """
    base = mirrors / repo.replace("/", "+")
    return next((d for d in (base / "repo", base, base / ".git") if (d / "HEAD").is_file()), None)


def list_tree(git_dir: Path) -> dict[str, TreeFile]:
    """Every file at HEAD, by path, with whether the snapshot holds its content.

    :param git_dir: the repository's git directory
    """
    files = {}
    for line in git(git_dir, "ls-tree", "-r", "HEAD").decode().splitlines():
        meta, path = line.split("\t", 1)
        _mode, kind, sha = meta.split()
        if kind == "blob":
            present = subprocess.run(["git", "--git-dir", str(git_dir), "cat-file", "-e", sha],
                                     capture_output=True).returncode == 0
            files[path] = TreeFile(path, sha, present)
    return files


def urdf_mesh_paths(text: str, urdf_path: str) -> tuple[list[str], list[str]]:
    """``(repository paths of the meshes a URDF references, references that are not repository paths)``.

    :param text: the URDF
    :param urdf_path: its path in the repository (relative references start from its folder)
    """
    local, other = [], []
    for mesh in ET.fromstring(text).iter("mesh"):
        name = mesh.get("filename", "")
        if "://" in name or name.startswith("/"):
            other.append(name)
        else:
            path = posixpath.normpath(posixpath.join(posixpath.dirname(urdf_path), name))
            if path not in local:
                local.append(path)
    return local, other


def run_files(run: Run, tree: dict[str, TreeFile], git_dir: Path
              ) -> tuple[list[TreeFile], list[str], list[TreeFile]]:
    """``(the files making the run folder, references to files the repository does not have, the mesh files its
    URDFs reference)``.

    :param run: the run
    :param tree: the repository's files
    :param git_dir: its git directory
    """
    prefix = f"{run.folder}/" if run.folder else ""
    if run.files:
        chosen = [tree[prefix + name] for name in run.files]
    else:
        chosen = [f for p, f in sorted(tree.items()) if p.startswith(prefix)]
    missing: list[str] = []
    referenced: list[TreeFile] = []
    for item in list(chosen):
        if item.path.endswith(".urdf") and item.present:
            local, other = urdf_mesh_paths(git(git_dir, "cat-file", "blob", item.sha).decode(), item.path)
            missing += other
            for path in local:
                if path not in tree:
                    missing.append(path)
                    continue
                if tree[path] not in referenced:
                    referenced.append(tree[path])
                siblings = [path] + ([path[:-4] + ".mtl"] if path.endswith(".obj") and path[:-4] + ".mtl" in tree
                                     else [])
                chosen += [tree[p] for p in siblings if tree[p] not in chosen]
    return chosen, missing, referenced


def lay_out(files: list[TreeFile], run: Run, git_dir: Path, target: Path) -> None:
    """Write the run folder ``target``: each present file at its path relative to the run's folder.

    :param files: the run's files
    :param run: the run
    :param git_dir: the repository's git directory
    :param target: the run folder to write (replaced)
    """
    shutil.rmtree(target, ignore_errors=True)
    target.mkdir(parents=True)
    for item in files:
        if item.present:
            relative = posixpath.relpath(item.path, run.folder or ".")
            (target / relative).parent.mkdir(parents=True, exist_ok=True)
            (target / relative).write_bytes(git(git_dir, "cat-file", "blob", item.sha))


# ----- the objects ---------------------------------------------------------------------------------------------
def local_objects(shared: Path) -> dict[str, dict]:
    """The local objects by id: ``{"folder", "model_id", "category"}``.

    :param shared: the folder holding ``partnet_dev/`` and ``real_objects/``
    """
    found = {}
    for meta in sorted(shared.glob("*/*/meta.json")):
        if meta.parent.parent.name in ("partnet_dev", "real_objects"):
            data = json.loads(meta.read_text())
            found[meta.parent.name] = {"folder": meta.parent, "model_id": data.get("model_id", ""),
                                       "category": data.get("model_cat", "")}
    return found


def objects_of(run: Run, run_dir: Path, local: dict[str, dict]) -> tuple[list[str], list[str]]:
    """``(the names the output gives its object, the local ids among them)``.

    :param run: the run
    :param run_dir: its laid-out folder
    :param local: :func:`local_objects`
    """
    by_model = {o["model_id"]: oid for oid, o in local.items() if o["model_id"]}
    names, matches = [], []
    if run.id_in_path:
        names.append(f"PartNet-Mobility {run.id_in_path}")
        if run.id_in_path in local:
            matches.append(run.id_in_path)
    for urdf in sorted(run_dir.rglob("*.urdf")):
        found = ROBOT_NAME.match(ET.fromstring(urdf.read_text()).get("name", ""))
        if found and f"model_id {found[1]}" not in names:
            names.append(f"model_id {found[1]}")
            if found[1] in by_model and by_model[found[1]] not in matches:
                matches.append(by_model[found[1]])
    return names, matches


# ----- reading -------------------------------------------------------------------------------------------------
def read_with(fmt: str | None, run_dir: Path, preview: tuple[str, ...] = ()) -> tuple[str, bool]:
    """``(what the format's reader made of the run folder, whether it imported)``.

    :param fmt: the format (None: no format reads this output)
    :param run_dir: the run folder
    :param preview: formats whose reader (``spark_bench.formats.<fmt>:read_run``) is read before it is in
        FORMATS: what it makes of the run is reported as a preview, and nothing is scored with it
    """
    import importlib

    from spark_bench.errors import InputError
    from spark_bench.formats import FORMATS
    from spark_bench.formats.foreign import to_benchmark
    from spark_bench.formats.runs import reader_of

    if fmt is None:
        return "no importer: not an object file (a program in the method's own API)", False
    if fmt == SPARK:
        return read_spark(run_dir)
    registered = fmt in FORMATS
    if not registered and fmt not in preview:
        files = sorted(str(f.relative_to(run_dir)) for f in run_dir.rglob(f"*.{fmt}"))
        return (f"awaiting the {fmt} reader (`spark_bench/formats/{fmt}.py`, not in FORMATS yet); it would read "
                f"{' or '.join(f'`{f}`' for f in files) or 'no such file here'}"), False
    note = "" if registered else f"preview of `spark_bench/formats/{fmt}.py`, not in FORMATS yet: "
    read = reader_of(fmt) if registered else importlib.import_module(f"spark_bench.formats.{fmt}").read_run
    try:
        found = read(run_dir)
        asset, _record = to_benchmark(found, run_dir.name)
    except InputError as exc:
        return note + "InputError: " + " ".join(str(exc).replace(str(run_dir), "RUN").split()), False
    except Exception as exc:  # a reader's bug: reported as such, the other runs go on
        return note + f"unexpected {type(exc).__name__}: {' '.join(str(exc).split())[:300]}", False
    return note + summary(asset, found.articulated, (found.record.get("files") or [""])[0]), registered


def summary(asset, articulated: bool, first_file: str) -> str:
    """One line on an imported object: its links, its movable joints, the file read first.

    :param asset: the object (:class:`~spark_bench.asset.model.ArticulatedAsset`)
    :param articulated: False for a shape-only format
    :param first_file: the file the reader read first ("" when it does not say)
    """
    movable = [j.type for j in asset.joints.values() if j.type != "fixed"]
    kinds = ", ".join(f"{movable.count(t)} {t}" for t in sorted(set(movable))) or "no movable joint"
    return (f"imports: {len(asset.links)} links, {kinds}{'' if articulated else ' (shape only)'}"
            f"{f' (reads `{first_file}`)' if first_file else ''}")


def read_spark(run_dir: Path) -> tuple[str, bool]:
    """What ``import spark``'s reader makes of a SPARK output folder, and whether it imported.

    :param run_dir: the run folder
    """
    from spark_bench.errors import InputError
    from spark_bench.formats.spark.reader import read_spark_run

    try:
        found = read_spark_run(run_dir)
    except InputError as exc:
        return "InputError: " + " ".join(str(exc).replace(str(run_dir), "RUN").split()), False
    except Exception as exc:  # a reader's bug: reported as such, the other runs go on
        return f"unexpected {type(exc).__name__}: {' '.join(str(exc).split())[:300]}", False
    return summary(found.asset, True, str(found.record.get("urdf", ""))), True


@dataclass
class RunResult:
    """One run, inventoried and read.

    :param shipped: its output
    :param run: the run
    :param commit: the commit read
    :param files: its files (present or not)
    :param missing: references to files the repository does not have
    :param names: the names the output gives its object
    :param matches: the local ids among them
    :param reading: what the reader made of it
    :param imported: whether it imported
    :param run_dir: its laid-out folder
    :param stamp: the commit's time, ``YYYYmmdd_HHMMSS``
    :param referenced: the mesh files its URDFs reference
    :param score_dirs: the run folders it was scored from (one per local object)
    """

    shipped: Shipped
    run: Run
    commit: str
    files: list[TreeFile]
    missing: list[str]
    names: list[str]
    matches: list[str]
    reading: str
    imported: bool
    run_dir: Path
    stamp: str = ""
    referenced: list[TreeFile] = field(default_factory=list)
    score_dirs: list[Path] = field(default_factory=list)

    def mesh_counts(self) -> str:
        """The part meshes in the snapshot: those its URDFs reference, else every mesh file of the run."""
        meshes = self.referenced or [f for f in self.files if f.path.lower().endswith(MESH_ENDINGS)]
        if not meshes:
            return "none"
        present = sum(f.present for f in meshes)
        text = f"{present} of {len(meshes)}"
        if present < len(meshes):
            text += " (absent: " + ", ".join(posixpath.basename(f.path) for f in meshes if not f.present) + ")"
        return text


def inventory_runs(shipped: Shipped, git_dir: Path, work: Path, local: dict[str, dict],
                   preview: tuple[str, ...] = ()) -> list[RunResult]:
    """Lay out and read every run of one shipped output.

    :param shipped: the output
    :param git_dir: its repository's git directory
    :param work: the working folder (runs go to ``work/runs/<case>/``)
    :param local: :func:`local_objects`
    :param preview: formats read before they are in FORMATS (:func:`read_with`)
    """
    commit = git(git_dir, "rev-parse", "HEAD").decode().strip()
    stamp = git(git_dir, "log", "-1", "--format=%cd", "--date=format:%Y%m%d_%H%M%S", "HEAD").decode().strip()
    tree = list_tree(git_dir)
    results = []
    for run in shipped.runs:
        files, missing, referenced = run_files(run, tree, git_dir)
        run_dir = work / "runs" / run.case
        lay_out(files, run, git_dir, run_dir)
        names, matches = objects_of(run, run_dir, local)
        reading, imported = read_with(shipped.fmt, run_dir, preview)
        results.append(RunResult(shipped, run, commit, files, missing, names, matches, reading, imported, run_dir,
                                 stamp, referenced))
    return results


# ----- scoring -------------------------------------------------------------------------------------------------
def spark_bench(*args: str) -> str:
    """Run ``spark-bench ARGS`` (this interpreter's package) and return its output.

    :param args: the command line
    """
    done = subprocess.run([sys.executable, "-m", "spark_bench.cli", *args], capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"spark-bench {' '.join(args)} failed ({done.returncode}): {done.stderr[-2000:]}")
    return done.stdout


def label_of(shipped: Shipped) -> str:
    """The leaderboard label of a method's shipped output."""
    return f"{shipped.method} (shipped output)"


def score(results: list[RunResult], local: dict[str, dict], work: Path) -> str:
    """Prepare the matched local objects, import and evaluate each method's matched runs; the leaderboard.

    :param results: every run (those that imported and match a local object are scored)
    :param local: :func:`local_objects`
    :param work: the working folder (``work/score/``: the objects, the benchmark, predictions, results store)
    :returns: the Markdown leaderboard ("" when nothing scored)
    """
    scored = [r for r in results if r.imported and r.matches]
    if not scored:
        return ""
    root = work / "score"
    shutil.rmtree(root, ignore_errors=True)
    src, bench, db = root / "src", root / "shipped-outputs-local", root / "results.sqlite"
    src.mkdir(parents=True)
    for oid in sorted({oid for r in scored for oid in r.matches}):
        (src / oid).symlink_to(local[oid]["folder"].resolve())
    spark_bench("data", "prepare", "--src", str(src), "--out", str(bench), "--image-size", "256", "--workers", "1",
                "--no-progress")
    labels = []
    for method in sorted({r.shipped.method for r in scored}):
        mine = [r for r in scored if r.shipped.method == method]
        fmt, slug = mine[0].shipped.fmt or "", re.sub(r"[^a-z0-9]+", "-", method.lower()).strip("-")
        runs, pred = root / "runs" / slug, root / "pred" / slug
        for result in mine:
            for oid in result.matches:  # one run per case: a second run of the same object is not scored
                # SPARK's importer finds its runs as <image name>_<timestamp>: the commit's time stands in
                name = f"{oid}_{result.stamp}" if fmt == SPARK else oid
                if not any(p.name.split("_")[0] == oid for p in runs.glob("*")):
                    shutil.copytree(result.run_dir, runs / name)
                    result.score_dirs.append(runs / name)
        spark_bench("import", fmt, "--runs", str(runs), "--bench", str(bench), "--out", str(pred))
        labels.append(label_of(mine[0].shipped))
        spark_bench("eval", "--method", "predictions", "--predictions", str(pred), "--bench", str(bench),
                    "--label", labels[-1], "--align", "icp", "--db", str(db), "--workers", "1", "--no-progress")
    methods = [arg for label in labels for arg in ("--methods", label)]
    return spark_bench("leaderboard", "--format", "md", "--db", str(db), *methods)


# ----- the report ----------------------------------------------------------------------------------------------
def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def report(results: list[RunResult], absent: list[str], commits: dict[str, str], board: str,
           local: dict[str, dict]) -> str:
    """The Markdown report.

    :param results: every run
    :param absent: the repositories with no snapshot under ``--mirrors``
    :param commits: the commit read of each repository
    :param board: the leaderboard ("" when nothing scored)
    :param local: :func:`local_objects`
    """
    lines = ["# Other methods' real shipped outputs (issue #24, item 4)", "",
             "Made by `benchmarks/measure_shipped_outputs.py` from snapshots of each method's public repository "
             f"(commit read below) and the {len(local)} local objects (`partnet_dev/`, `real_objects/`). Every "
             "row is the method's **shipped output**, read as shipped; nothing was re-run.", ""]
    scored = [r for r in results if r.score_dirs]
    if scored:
        lines += [f"**Scored**: {len(scored)} run(s) of {len({r.shipped.method for r in scored})} method(s) on "
                  "local objects, below.", ""]
    else:
        lines += ["**Nothing scored**: no shipped output is of one of the local objects (or, where one is, it "
                  "is not an object spark-bench can import). No output was scored against another object.", ""]
    lines += ["## Shipped outputs", "",
              "| Method | Repository @ commit | Path | What it is | Object (how known) | Meshes in snapshot |",
              "|---|---|---|---|---|---|"]
    for shipped in SHIPPED:
        mine = [r for r in results if r.shipped is shipped]
        meshes = "; ".join(f"{r.run.case}: {r.mesh_counts()}" for r in mine) or "repository absent"
        lines.append(f"| {shipped.method} | `{shipped.repo}` @ `{commits.get(shipped.repo, 'absent')[:12]}` | "
                     f"`{shipped.path}` | {_cell(shipped.what)} | {_cell(shipped.obj)} | {_cell(meshes)} |")
    lines += ["", "## Repositories that ship no output of their method", "",
              "| Method | Repository @ commit | What it ships instead |", "|---|---|---|"]
    for entry in NO_OUTPUT:
        commit = commits.get(entry.repo, "")[:12] or entry.commit or "absent"
        lines.append(f"| {entry.method} | `{entry.repo}` @ `{commit}` | {_cell(entry.ships)} |")
    lines += ["", "## Each run, read with spark-bench's importer", "",
              "Laid out as `DIR/<case>/` exactly as shipped (the output folder's files; a URDF's meshes at the "
              "paths it references, so URDFormer's run folder holds `output/labelN.urdf` and `meshes/...`).", "",
              "| Case | Format | Files (absent from snapshot) | Object named | Local? | Reader |", "|---|---|---|---|---|---|"]
    for r in results:
        absent_files = [posixpath.basename(f.path) for f in r.files if not f.present]
        files = f"{len(r.files)}" + (f" ({len(absent_files)}: {', '.join(absent_files)})" if absent_files else "")
        if r.missing:
            files += "; not in the repository: " + ", ".join(r.missing)
        named = ", ".join(r.names) or "none"
        lines.append(f"| {r.run.case} | {r.shipped.fmt or '-'} | {_cell(files)} | {_cell(named)} | "
                     f"{', '.join(r.matches) or 'no'} | {_cell(r.reading)} |")
    if absent:
        lines += ["", "Repositories without a snapshot under `--mirrors`: " + ", ".join(f"`{a}`" for a in absent)]
    if board:
        lines += ["", "## Leaderboard (shipped outputs on local objects)", "", board.strip()]
    lines += ["", "## Notes", ""] + [f"- {note}" for note in NOTES]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mirrors", type=Path, required=True, help="folder of repository snapshots (git dirs)")
    parser.add_argument("--shared", type=Path, default=Path("../shared"), help="folder of partnet_dev/, real_objects/")
    parser.add_argument("--work", type=Path, default=Path("/tmp/realout"), help="working folder (runs, benchmark)")
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/shipped_outputs.md"))
    parser.add_argument("--preview", action="append", default=[], metavar="FMT",
                        help="also read with spark_bench/formats/FMT.py before it is in FORMATS (reported as a "
                             "preview, never scored)")
    args = parser.parse_args(argv)
    local = local_objects(args.shared)
    if not local:
        parser.error(f"no local objects under {args.shared} (partnet_dev/<id>/meta.json, real_objects/<id>/meta.json)")
    results, absent, commits = [], [], {}
    for repo in sorted({s.repo for s in SHIPPED} | {n.repo for n in NO_OUTPUT}):
        git_dir = git_dir_of(args.mirrors, repo)
        if git_dir is None:
            absent.append(repo)
            continue
        commits[repo] = git(git_dir, "rev-parse", "HEAD").decode().strip()
        paths = set(git(git_dir, "ls-tree", "-r", "--name-only", "HEAD").decode().splitlines())
        for entry in (n for n in NO_OUTPUT if n.repo == repo):
            for path in entry.check:
                if path not in paths:
                    print(f"warning: {repo}@{commits[repo][:12]} has no {path}: its listing is out of date")
        for shipped in (s for s in SHIPPED if s.repo == repo):
            results += inventory_runs(shipped, git_dir, args.work, local, tuple(args.preview))
    absent = [a for a in absent if not any(n.repo == a and n.commit for n in NO_OUTPUT)]
    board = score(results, local, args.work)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report(results, absent, commits, board, local))
    for r in results:
        print(f"{r.run.case}: {r.reading}" + (f" [local {', '.join(r.matches)}]" if r.matches else ""))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
