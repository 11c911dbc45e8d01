"""The field's named test splits: the PartNet-Mobility ids each method publishes as its test set, where they
were read, and the camera each method states for its inputs.

Every :class:`Split` here is a listed benchmark of :data:`spark_bench.data.benchmarks.BENCHMARKS`: its
meshes cannot be shipped, so ``spark-bench data prepare --src PARTNET_MOBILITY_DIR --bench NAME`` prepares
the ids found in a user's download and lists the others as missing. This module is plain data (no heavy
imports): ``spark-bench data prepare --help`` lists the names from it.

**Ids.** Each tuple is the file's own list, in its order, as strings of digits; a ``Category/id`` entry
keeps its id. Every id of every split below is a PartNet-Mobility id: each was checked against the 2,347 ids
of ``partnet_obj_types.json`` in Articulate-Anything's repository (``vlongle/articulate-anything`` at
1edb4b4a, 2025-03-11), which lists the whole dataset by category. Entries of other datasets (SINGAPO's
ACD test set) are left out, said in the split's ``notes``.

**Cameras** (:mod:`spark_bench.data.camera`): the benchmark frame is Z up with the front towards -X and the
object's rest box centred at the origin, its longest side 2; azimuth is measured from +X towards +Y (180:
straight at the front). The methods render PartNet-Mobility's meshes (Y up, front +Z) in Blender, whose OBJ
and glTF importers turn them Z up with the front towards Blender's -Y (SINGAPO's ``render_script.py``
marks ``-pi/2`` as the front view): a Blender azimuth ``theta`` is our ``theta - 90`` degrees, elevations
are the same. A distance in PartNet-Mobility's own units (meshes as the dataset ships them, longest side
1.50 for the median object) is scaled by :data:`PARTNET_MOBILITY_TO_BENCH` (2 / 1.50). Views drawn at
random within ranges map onto the seeded front view of :class:`~spark_bench.data.prepare.PrepareOptions`
(azimuth 180 +- 60, elevation 10 to 40 degrees); a single fixed view maps onto a fixed azimuth and
elevation. A method that states no camera gets the benchmark's default view (:data:`DEFAULT_VIEW`).
Renders stay 512 px, as for ``spark-test`` (``--image-size`` changes it); the method's own size is in its
``camera`` text.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from spark_bench.data.camera import DEFAULT_DISTANCE, DEFAULT_FOV_DEG, SPARK_AZIMUTH_DEG, SPARK_ELEVATION_DEG

#: 2 / the median longest side (1.50, 10th-90th percentile 1.30-1.70) of the rest boxes of the 82 real
#: PartNet-Mobility objects under ``../shared`` (``real_objects`` and ``partnet_dev``), meshes as shipped:
#: a distance in the dataset's own units times this is the distance in the benchmark frame, for that object.
PARTNET_MOBILITY_TO_BENCH = 2.0 / 1.50


@dataclass(frozen=True)
class View:
    """The camera a split is prepared with: the fields of the same names of ``PrepareOptions``.

    :param fov_deg: vertical field of view in degrees
    :param distance: camera distance from the rest box's centre, in the benchmark frame
    :param azimuth_deg: a fixed azimuth (degrees from +X towards +Y; 180: the front), or None for the
        seeded front view of each case
    :param elevation_deg: the fixed elevation (degrees above the XY plane), with ``azimuth_deg``
    """

    fov_deg: float = DEFAULT_FOV_DEG
    distance: float = DEFAULT_DISTANCE
    azimuth_deg: float | None = None
    elevation_deg: float | None = None


#: The benchmark's own view: a seeded view of the front hemisphere, radius 4, 40 degrees.
DEFAULT_VIEW = View()


@dataclass(frozen=True)
class Split:
    """One method's published test split.

    :param name: the benchmark name (``data prepare --bench NAME``)
    :param method: the method that publishes it
    :param ids: its PartNet-Mobility ids, in the file's order
    :param repo: the GitHub repository read (``owner/name``)
    :param path: the file in it that lists the ids
    :param commit: the commit read (the snapshot's newest) and its date
    :param read: how the ids were taken from the file
    :param camera: what the method states about its input camera, with the file, and how it maps onto
        :attr:`view` (or that it states none)
    :param view: the camera the benchmark is prepared with
    :param notes: ids left out and why, who else uses the split, what differs from the method's own test
    """

    name: str
    method: str
    ids: tuple[str, ...]
    repo: str
    path: str
    commit: str
    read: str
    camera: str
    view: View = DEFAULT_VIEW
    notes: tuple[str, ...] = field(default=())

    @property
    def source(self) -> str:
        """``owner/name:path@commit``: where the ids come from (the commit without its date)."""
        return f"{self.repo}:{self.path}@{self.commit.split()[0]}"


# ----- SPARK -----------------------------------------------------------------------------------------
#: SPARK's test objects: the ``SELECT`` list of ``datasets/create_testset.py`` in SPARK's code
#: (``mebam1/spark``), 42 PartNet-Mobility ids, in its order.
SPARK_TEST_IDS = (
    "100162", "100202", "100448", "100473", "101362", "102834", "103048", "103105", "12092", "12540",
    "8867", "8897", "100021", "100051", "10090", "10101", "7221", "7236", "101773", "101931",
    "103863", "103872", "10627", "10900", "100828", "101011", "101593", "102301", "35059", "44817",
    "100550", "100825", "20411", "25913", "103477", "103482", "101323", "102632", "101377", "102155",
    "103518", "103521",
)
#: SPARK's rendering (``datasets/preprocess/render.py``): camera on a sphere of radius 4, 40 degree field of
#: view, azimuth 0 and elevation 0 of its mesh frame (our front view, level).
SPARK_TEST_VIEW = View(DEFAULT_FOV_DEG, DEFAULT_DISTANCE, SPARK_AZIMUTH_DEG, SPARK_ELEVATION_DEG)

# ----- SINGAPO (and DIPO) ----------------------------------------------------------------------------
SINGAPO_TEST_IDS = (
    "23807", "30238", "31601", "32566", "26503", "22241", "19855", "25144", "31249", "27619", "35059",
    "48721", "48167", "45620", "47315", "46029", "46107", "46787", "45699", "47168", "45415", "45915",
    "45600", "48023", "45173", "45908", "46179", "45717", "46439", "41086", "47180", "45423", "46045",
    "48177", "45575", "44826", "49133", "45662", "45162", "45235", "48513", "49038", "45573", "47185",
    "47747", "46480", "45612", "47648", "48797", "45135", "45661", "47233", "48740", "45323", "45219",
    "46108", "46549", "47227", "46002", "45696", "47701", "46955", "46655", "46896", "46981", "103425",
    "12587", "12414", "12562", "12592", "11846", "10347", "10685", "12252", "7320", "7130", "7179",
)
#: SINGAPO renders with radius U(3, 3.5) in the dataset's units: 3.25 at the midpoint, about 4.3 here.
SINGAPO_VIEW = View(distance=round(3.25 * PARTNET_MOBILITY_TO_BENCH, 1))

# ----- CAGE ------------------------------------------------------------------------------------------
CAGE_TEST_IDS = (
    "25959", "23807", "30238", "31601", "33914", "32566", "26503", "22241", "19855", "25144", "35059",
    "48721", "48167", "45620", "47315", "46029", "46107", "46787", "45699", "47168", "45415", "45915",
    "45600", "48023", "45173", "45908", "46179", "45717", "46439", "41086", "47180", "45423", "46045",
    "48177", "45575", "44826", "49133", "45662", "45162", "45235", "48513", "49038", "45573", "47185",
    "47747", "46480", "45612", "47648", "48797", "45135", "45661", "47233", "48740", "45323", "45219",
    "46108", "46549", "47227", "46002", "45696", "47701", "46955", "46655", "46896", "46981", "103425",
    "102309", "102311", "101594", "102318", "102380", "12578", "12587", "12414", "12562", "12592", "11846",
    "10347", "10685", "11231", "12252",
)

# ----- FreeArt3D -------------------------------------------------------------------------------------
FREEART3D_TEST_IDS = (
    "100214", "100129", "100664", "102379", "100141", "100247", "102377", "100234", "100243", "100426",
    "100671", "102456", "12583", "12259", "12605", "12580", "12596", "12414", "12606", "12614", "12065",
    "12597", "12536", "12565", "10885", "9918", "11075", "9748", "10090", "10238", "11405", "10270", "10289",
    "10356", "9996", "11477", "103516", "100310", "100354", "100319", "100335", "100317", "100350", "100321",
    "100289", "100318", "100309", "100311", "7263", "7296", "7306", "7320", "7167", "7128", "7273", "7236",
    "7292", "7366", "7304", "7265", "102018", "101917", "101808", "101971", "7290", "7179", "7130", "101773",
    "101909", "102001", "102044", "7201", "10655", "12038", "11712", "12036", "12043", "11550", "11231",
    "10751", "10612", "12050", "10347", "12054", "101593", "101611", "102301", "102389", "101604", "101363",
    "102309", "101564", "101619", "101584", "101599", "101623", "103297", "103299", "103113", "103293",
    "103273", "103271", "103792", "103305", "103307", "103095", "103111", "103276", "47185", "45790", "45694",
    "46839", "47711", "46084", "46653", "46544", "45676", "45841", "45427", "47183", "26657", "20411",
    "33457", "28668", "22508", "26525", "31601", "30857", "32174", "22301", "20985", "20555", "103425",
    "103361", "103776", "103775", "103518", "103490", "100283", "103778", "103528", "103351", "103521",
    "103508",
)
#: FreeArt3D's ``run_rendering``: horizontal distance 2.1 x the longest side of the box, height
#: sin(45 deg) x that distance above the box centre, azimuth pi/8 from the front towards Blender's +X.
_FREEART3D_REACH = 2.1
_FREEART3D_RISE = math.sin(math.radians(45.0))
FREEART3D_VIEW = View(
    fov_deg=45.0,
    # the longest side is 2 in the benchmark frame
    distance=round(_FREEART3D_REACH * 2.0 * math.hypot(1.0, _FREEART3D_RISE), 3),
    # Blender's +X is the mesh's +X, our -Y: pi/8 past the front (180) towards -Y
    azimuth_deg=SPARK_AZIMUTH_DEG + 22.5,
    elevation_deg=round(math.degrees(math.atan(_FREEART3D_RISE)), 3),
)

# ----- PhysX-Anything --------------------------------------------------------------------------------
PHYSX_ANYTHING_TEST_IDS = (
    "103189", "101843", "102611", "101300", "101863", "101831", "103186", "101859", "101868", "103177",
    "101840", "101839", "102596", "103015", "102805", "103321", "103042", "103056", "103339", "102981",
    "103316", "102984", "102985", "103333", "45248", "45297", "45633", "45332", "45387", "45415", "46801",
    "45632", "45776", "45244", "45092", "45612", "47577", "47183", "48859", "48855", "45915", "47021",
    "45162", "45606", "47089", "45427", "45940", "47711", "46107", "47701", "49062", "46655", "48479",
    "45463", "48271", "47443", "49133", "47613", "45936", "47686", "45694", "46456", "46879", "41086",
    "45249", "48452", "45271", "48169", "45134", "47238", "45749", "45756", "47182", "46922", "47088",
    "46123", "45948", "45238", "46045", "48876", "45717", "47278", "47466", "45397", "48167", "47976",
    "45780", "35059", "46060", "48258", "47944", "103723", "103740", "103735", "101106", "103716", "103585",
    "101115", "101068", "101892", "100508", "100496", "101060", "101083", "100856", "100488", "100861",
    "100491", "101077", "101055", "100084", "12038", "11299", "12250", "11260", "19836", "26073", "20043",
    "19825", "23782", "28164", "30857", "32761", "33914", "30869", "32601", "23472", "24644", "103853",
    "103866", "103996", "103867", "104030", "101015", "101014", "100270", "104044", "104041", "104045",
    "100809", "100405", "101011", "102952", "102915", "102916", "102962", "102942", "101793", "101736",
    "102973", "101748", "7221", "7306", "100911", "102844", "102836", "100880", "100914", "100965", "100948",
    "100883", "100924", "100978", "100976", "100871", "100954", "100902", "101561", "101563", "101539",
    "103394", "103405", "103380", "101560", "103359", "101517", "102890", "102527", "102539", "101352",
    "102523", "102506", "102432", "100448", "100442", "100482", "100472", "100435", "100468", "102358",
    "1028", "866", "1785", "1886", "1444", "1528", "1961", "1646", "1053", "1034", "1741", "811", "908",
    "2035", "2140", "102620", "101319", "102703", "102650", "102622", "102679", "102684", "102707", "102708",
    "102646", "102697", "102694", "102660", "103084", "103128", "103072", "103086", "103071", "102149",
    "103048", "103125", "102901", "103137", "48492", "102377", "100221", "100141", "100129", "12836", "13106",
    "13075", "12834", "12838", "13082", "13004", "100755", "103968", "100751", "100739", "100736", "100789",
    "100741", "100790", "100754", "100750", "100744", "100795", "100523", "100590", "100608", "100562",
    "11429", "9960", "9918", "10269", "9912", "9748", "10243", "11854", "12073", "10098", "10270", "102258",
    "100172", "100188", "100178", "101593", "101612", "102387", "102381", "101591", "102278", "4627", "4533",
    "4576", "3393", "4628", "4566", "4574", "13491", "10537", "10844", "11103", "10569", "11040", "10889",
    "10561", "11077", "10975", "102210", "102996", "102992", "103633", "102189", "102187", "102218", "102158",
    "102244", "100732", "101377", "102173", "103635", "101472", "101374", "101524", "101445", "101494",
    "101372", "101441", "101423", "101461", "102095", "101413", "101419", "102070", "101402", "103171",
    "101386", "100335", "100313", "103503", "103515", "100309", "103498", "103473", "103466", "103514",
    "103553", "3830", "6335", "3593", "100619", "100028", "100058", "100693", "100055", "7104", "6500",
    "6813", "7054", "7015", "102761", "3971", "102714", "100031", "101305", "101921", "102019", "101908",
    "102001", "102055", "101917", "12531", "11661", "12597", "102024", "101983", "101952", "102068", "102037",
    "100065", "100106", "100078", "101982", "100113", "8983", "8936", "101399", "101416", "103792", "103307",
    "103789", "103113", "103699", "103593", "103927", "101668", "100840", "101673", "100825", "103508",
    "103369", "103361",
)

# ----- Real2Code -------------------------------------------------------------------------------------
REAL2CODE_TEST_IDS = (
    "19855", "20985", "22241", "22301", "22433", "25493", "26387", "26652", "40417", "44781", "44817",
    "44853", "44962", "45243", "45248", "45271", "45332", "45423", "45505", "45523", "45662", "45693",
    "45694", "45699", "45747", "45779", "45922", "45940", "46172", "46762", "46787", "46955", "47419",
    "47742", "47976", "48263", "48271", "48356", "48467", "48855", "49025", "49133",
)
#: Real2Code's cameras: horizontal distance 3.6-3.9 (by object volume), height 0.3-0.7, in the dataset's
#: units: about 3.78 from the centre at the middle of both, about 5.0 here; BlenderProc's default field of
#: view (``DefaultConfig.fov`` = 0.691111 rad), which ``blender_render.py`` does not change.
REAL2CODE_VIEW = View(fov_deg=round(math.degrees(0.691111), 1),
                      distance=round(math.hypot(3.75, 0.5) * PARTNET_MOBILITY_TO_BENCH, 1))


SPLITS: dict[str, Split] = {split.name: split for split in (
    Split(
        "spark-test", "SPARK", SPARK_TEST_IDS, "mebam1/spark", "datasets/create_testset.py",
        "9b114a9dcd84da3fa21eec6e96097ecca183228d (the stored version; its date was not available)",
        read="the SELECT list (the --manual test set), in its order",
        camera="datasets/preprocess/render.py: render_single_view at azimuth 0, elevation 0 of its Y-up, "
               "front +Z mesh frame, radius 4, 40 degree field of view, 2048 px: our azimuth 180, elevation "
               "0, radius 4, 40 degrees (512 px)",
        view=SPARK_TEST_VIEW,
    ),
    Split(
        "singapo-test", "SINGAPO", SINGAPO_TEST_IDS, "3dlg-hcvc/singapo", "data/data_split.json",
        "2199ef8c223308e26f1e7928892e5f9786ff4fea 2025-02-27 (the file unchanged since 1910a07b, 2024-12-15)",
        read="the \"test\" list (77 \"Category/id\" entries, the PartNet-Mobility test set data/dataset.py "
             "and test.py --which_data pm read), its ids in its order",
        camera="scripts/preprocess/render_script.py (Blender, 20 views per object, 512 px, 40 degree field "
               "of view): radius U(3, 3.5) in the dataset's units (CAGE's preprocess.py, which SINGAPO's "
               "data comes from, keeps PartNet-Mobility's coordinates), polar angle in [pi/3, pi/2] from "
               "Blender's +Z (elevation 0-30 degrees), azimuth in [-5pi/6, -pi/6] about the front -pi/2 (our "
               "180 +- 60); data/dataset.py tests on views 18 and 19, centre-cropped to 224 and resized to "
               "128 px. Here: the seeded front view (the same azimuth span, elevation 10-40 instead of "
               "0-30), 40 degrees, radius 4.3 (3.25 x 2/1.50), 512 px",
        view=SINGAPO_VIEW,
        notes=(
            "DIPO (RQ-Wu/DIPO, 78efeff5, 2025-12-12) tests on this same file: its readme's Evaluation points "
            "to data/data_split.json, dataset/mydataset.py's example settings set split_file to "
            "singapo/data/data_split.json, and its repository has no split file of its own. Its renders "
            "(scripts/render/render_script.py) differ in the radius, U(4, 4.5), and in rendering each view "
            "at rest and opened.",
            "SINGAPO's other test set, data/data_acd.json (hssd-data/... entries of the ACD dataset), is not "
            "PartNet-Mobility: left out.",
            "4 test ids are also in the file's \"train\" list: 27619, 7320, 7130, 7179.",
        ),
    ),
    Split(
        "cage-test", "CAGE", CAGE_TEST_IDS, "3dlg-hcvc/cage", "indexes/data_split.json",
        "fb4a70c980848149e3938dab02f85145712831eb 2025-02-25 (the file unchanged since bb25c5b0, 2023-12-13)",
        read="the \"test\" list (81 \"Category/id\" entries), its ids in its order",
        camera="none: CAGE generates an object from a part graph (and category), not from an image; its "
               "utils/render.py only draws the results. Here: the benchmark's default view",
        notes=("Disjoint from the file's \"train\" list. SINGAPO's test set is this one less 25959, 33914, "
               "the 5 Safes, 12578 and 11231, plus 31249, 27619, 7320, 7130 and 7179.",),
    ),
    Split(
        "freeart3d-test", "FreeArt3D", FREEART3D_TEST_IDS, "PeterZs/FreeArt3D", "configs/partnet.json",
        "0320aebd0204bda8fe881dd83a90309f2ae80258 2025-11-09 (the file unchanged since 69c1a24e, 2025-10-29)",
        read="\"total_obj_ids\" (144 ids: 12 categories x 12, as configs/partnet_categories.json and the "
             "README's \"144 objects in 12 categories\"), the list preprocess_partnet_mesh.py and "
             "render_partnet_mesh.py read, in its order",
        camera="pipelines/render.py run_rendering (Blender): 45 degree field of view, 800 px, one view at "
               "azimuth pi/8 from the front towards Blender's +X, horizontal distance 2.1 x the longest side "
               "of the box of the last (most open) state, height sin(45 deg) x that above the box centre, "
               "i.e. 2.57 x the longest side away at elevation 35.26 degrees; inputs are 6 states of one "
               "joint on a blue disk. Here: azimuth 202.5, elevation 35.264, distance 5.144 (longest side 2, "
               "of the rest box), 45 degrees, 512 px",
        view=FREEART3D_VIEW,
        notes=(
            "The stored repository is PeterZs/FreeArt3D, which holds the authors' (CzzzzH) commits; the "
            "authors' own repository could not be fetched.",
            "The file's \"revolute\" list has 12 more ids (Display: 5088 4574 4094 5306 3393 4529 4586 4628 "
            "4589 4542 4533 5050) that are in neither total_obj_ids nor partnet_categories.json and that "
            "the scripts never read: left out.",
            "FreeArt3D articulates one joint per object (the first of its joints.json); the benchmark keeps "
            "every joint.",
        ),
    ),
    Split(
        "physx-anything-test", "PhysX-Anything", PHYSX_ANYTHING_TEST_IDS, "ziangcao0312/PhysX-Anything",
        "testset.npy",
        "dde27f88b987b640afa56679e2498550d656be4c 2025-11-27 (the file unchanged since 7c87bcc2, 2025-11-18)",
        read="numpy.load of the (388,) <U6 array, in its order; disjoint from trainingset.npy (1,636 ids)",
        camera="none for its test inputs, which come from the PhysX-Mobility dataset (Hugging Face "
               "Caoza/PhysX-Mobility), not the repository. render_urdf.py's PyBullet camera (60 degrees, "
               "distance 2, yaw -45, pitch -25, target (0, 0, 0.8), 512 px) films the generated URDFs for "
               "evaluation_kine.py, not the inputs. Here: the benchmark's default view",
    ),
    Split(
        "real2code-test", "Real2Code", REAL2CODE_TEST_IDS, "MandiZhao/real2code", "blender_render.py",
        "ecd50d27df34773ea82ec55c7af73ce33136c6fb 2025-03-05 (the list unchanged since baa6d51f, 2024-06-14)",
        read="the module docstring's \"Test set objects\" commands: 8 Table ids, then 34 StorageFurniture "
             "ids",
        camera="blender_render.py (BlenderProc, URDF world: front -X): 512 px, BlenderProc's default field "
               "of view (39.6 degrees), --num_frames views (2 by default) spread from azimuth 112.5+U(0, 30) "
               "to 240-U(0, 30) degrees, horizontal distance 3.6-3.9 by object volume (per-category and "
               "per-object overrides) at height 0.3-0.7 in the dataset's units, looking at the box centre "
               "shifted by U(-0.3, 0) and a random walk; RGB-D, joints set at random. Here: the seeded front "
               "view, 39.6 degrees, radius 5.0 (3.78 x 2/1.50), 512 px",
        view=REAL2CODE_VIEW,
        notes=("These are the Table and StorageFurniture test objects only: data_utils/data_proc.md speaks "
               "of other test objects (e.g. 5 Eyeglasses) whose ids are not in the repository; the full "
               "split is the test/ folder of Real2Code's released dataset (Google Drive).",),
    ),
)}
