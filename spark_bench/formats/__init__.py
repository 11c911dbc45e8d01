"""Other programs' output, read as they write it: one module (or folder) per format, each turning one
run of a method into an object folder in the benchmark frame, with the files of the method's code each
fact comes from.

- :mod:`.foreign`: what every format shares (the object read, into the benchmark frame, ``import.json``);
- :mod:`.runs`: ``spark-bench import FORMAT``: ``DIR/<case id>/`` -> ``PRED/<case id>/`` with any reader of
  :data:`FORMATS`;
- :mod:`.singapo`: SINGAPO / DIPO / CAGE (``object.json`` + ``plys/part_<i>.ply``);
- :mod:`.freeart3d`: FreeArt3D (``sds_output/joint_info.json`` + ``part_meshes/``);
- :mod:`.parts`: shape-only methods, one mesh per part (PartCrafter, OmniPart);
- :mod:`.anymesh`: Articulate AnyMesh (``mobility.json`` + ``mesh_parts/``);
- :mod:`.urdf`: any method's URDF (URDFormer, Articulate-Anything, PhysX-Anything's ``basic.urdf``; FreeArt3D's
  ``output.urdf`` through its ``joint_info.json``);
- :mod:`.mjcf`: any MJCF, read through MuJoCo (PhysX-Anything's ``basic.xml``, Particulate's export, Real2Code);
- :mod:`.usd`: any USD file with a UsdPhysics articulation (Infinigen-Sim's export, URDF -> USD converters,
  Isaac Sim asset sets), read with ``usd-core``;
- :mod:`.spark`: SPARK's run folders (its layout, the reader, ``spark-bench import spark``);
- :mod:`.commands`: the ``import`` command.

This package uses ``asset`` and ``data`` only; the methods (``methods/predictions``, ``ours``' ``spark``
geometry backend) use it.
"""

#: Format name -> its reader, ``module:function`` (imported when used): ``read_run(run_dir: Path) ->
#: ForeignObject``, raising :class:`~spark_bench.errors.InputError` naming the file and the problem. A new
#: format is one module with its reader and its facts, and one line here.
FORMATS: dict[str, str] = {
    "singapo": "spark_bench.formats.singapo:read_run",  # SINGAPO, DIPO and CAGE write the same object.json
    "freeart3d": "spark_bench.formats.freeart3d:read_run",
    "parts": "spark_bench.formats.parts:read_run",  # shape only: PartCrafter, OmniPart
    "anymesh": "spark_bench.formats.anymesh:read_run",  # Articulate AnyMesh
    "mjcf": "spark_bench.formats.mjcf:read_run",  # PhysX-Anything's basic.xml, Particulate, Real2Code
    # any method's URDF: URDFormer, Articulate-Anything, PhysX-Anything (FreeArt3D's output.urdf via joint_info.json)
    "urdf": "spark_bench.formats.urdf:read_run",
    "usd": "spark_bench.formats.usd:read_run",  # UsdPhysics articulations: Infinigen-Sim, Isaac Sim assets
}

#: Format name -> the file suffixes a case's run may be besides a folder, ``DIR/<case id><suffix>`` (one model
#: file per case); a format not listed reads folders only.
RUN_FILE_SUFFIXES: dict[str, tuple[str, ...]] = {"usd": (".usd", ".usda", ".usdc", ".usdz")}
