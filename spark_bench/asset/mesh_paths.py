"""Where a URDF's ``<mesh filename>`` points: as ROS resolves it, or confined to an object folder.

Two ways to read a URDF, by who handed it over:

- **as it lies** (a URDF the user names directly: ``check``, ``convert``, ``metrics``, ``rollout --asset``):
  every path resolves as ROS and the tools built on it do (``resource_retriever``, ``urdf_parser``,
  URDFormer's own loader): a relative path is relative to the URDF's folder, ``..`` included;
  ``package://NAME/rest`` is ``rest`` inside package ``NAME``, found as a folder named ``NAME`` in one of
  the package paths (``--package-path DIR``, repeatable, then the ``ROS_PACKAGE_PATH`` entries, ``:``
  separated), a package path that is itself named ``NAME``, or a folder ``NAME`` with a ``package.xml``
  a few levels below one (a catkin/colcon workspace), or a folder ``NAME`` above the URDF; ``file://`` and
  absolute paths are taken as written. URDFormer's predictions (``output/label*.urdf``) name ``../meshes/...``.
- **confined** (folders spark-bench did not get from the user directly: benchmark cases, ``import`` runs):
  the path must stay inside the object folder; ``package://`` and ``file://`` prefixes are dropped (the
  rest is relative to the URDF), as before.

A path that cannot be resolved is an :class:`~spark_bench.errors.InputError` naming the URDF.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from spark_bench.errors import InputError

PACKAGE_PREFIX = "package://"
FILE_PREFIX = "file://"
#: The environment variable ROS 1 reads package folders from (``:``-separated, searched in order).
ROS_PACKAGE_PATH = "ROS_PACKAGE_PATH"
#: How deep below a package path a package folder (one holding ``package.xml``) is looked for.
PACKAGE_DEPTH = 3
#: What the refusal of a path outside a confined folder tells the user to do instead.
AS_IT_LIES_HINT = ("to resolve it as ROS does, name the URDF file itself (check, convert, metrics and rollout "
                   "--asset take FILE.urdf; --package-path DIR for package:// paths)")


def package_paths_from_environment() -> list[Path]:
    """The folders of ``ROS_PACKAGE_PATH`` (empty entries dropped), in order."""
    text = os.environ.get(ROS_PACKAGE_PATH, "")
    return [Path(part).expanduser() for part in text.split(os.pathsep) if part.strip()]


@dataclass
class MeshPathResolver:
    """Resolves the mesh file names of one URDF.

    :param urdf: the URDF file (resolved)
    :param folder: the object folder paths must stay inside; None reads the URDF as it lies (ROS rules)
    :param package_paths: folders searched for ``package://NAME/`` before ``ROS_PACKAGE_PATH``
    """

    urdf: Path
    folder: Path | None = None
    package_paths: Sequence[Path] = field(default_factory=list)

    @property
    def confined(self) -> bool:
        """Whether paths must stay inside :attr:`folder`."""
        return self.folder is not None

    def search_paths(self) -> list[Path]:
        """The package folders, ``--package-path`` first, then ``ROS_PACKAGE_PATH``."""
        return [Path(p).expanduser() for p in self.package_paths] + package_paths_from_environment()

    def find_package(self, name: str) -> Path | None:
        """The folder of package ``name``: ``DIR/NAME`` for a search folder ``DIR``, ``DIR`` itself when it is
        named ``name``, else a folder ``NAME`` holding a ``package.xml`` up to :data:`PACKAGE_DEPTH` levels
        below ``DIR`` (a workspace's ``src/<group>/NAME``, as ROS crawls its package path); None when none."""
        for base in self.search_paths():
            if (base / name).is_dir():
                return (base / name).resolve()
            if base.name == name and base.is_dir():
                return base.resolve()
        for base in self.search_paths():
            for depth in range(1, PACKAGE_DEPTH + 1):
                found = next(base.glob("/".join(["*"] * depth + [name, "package.xml"])), None)
                if found is not None:
                    return found.parent.resolve()
        return None

    def resolve(self, filename: str) -> Path:
        """The file ``filename`` names (resolved, not checked to exist).

        :param filename: the ``<mesh filename>`` as the URDF writes it
        :raises InputError: confined and outside the folder, or a ``package://`` whose package is on no path
        """
        if self.confined:
            return self._confined(filename)
        if filename.startswith(FILE_PREFIX):
            return Path(filename[len(FILE_PREFIX):]).expanduser().resolve()
        if filename.startswith(PACKAGE_PREFIX):
            return self._package(filename)
        candidate = Path(filename).expanduser()
        return (candidate if candidate.is_absolute() else self.urdf.parent / candidate).resolve()

    def _confined(self, filename: str) -> Path:
        name = filename
        for prefix in (PACKAGE_PREFIX, FILE_PREFIX):
            if name.startswith(prefix):
                name = name[len(prefix):]
        candidate = Path(name)
        resolved = (candidate if candidate.is_absolute() else self.urdf.parent / candidate).resolve()
        if not resolved.is_relative_to(self.folder):
            raise InputError(self.urdf, f"mesh path {filename!r} escapes the object folder; {AS_IT_LIES_HINT}")
        return resolved

    def _package(self, filename: str) -> Path:
        rest = filename[len(PACKAGE_PREFIX):]
        name, _, inside = rest.partition("/")
        package = self.find_package(name)
        if package is not None:
            return (package / inside).resolve()
        # no package folder given: a URDF shipped inside its package (URDF in NAME/urdf/, meshes in NAME/meshes/)
        for parent in self.urdf.parents:
            if parent.name == name:
                return (parent / inside).resolve()
        beside = (self.urdf.parent / rest).resolve()  # how spark-bench read package:// paths before
        if beside.is_file():
            return beside
        searched = [str(p) for p in self.search_paths()] or ["none given"]
        raise InputError(self.urdf, f"mesh path {filename!r}: package {name!r} not found on the package paths "
                                    f"({', '.join(searched)}); give its parent folder with --package-path DIR "
                                    f"or {ROS_PACKAGE_PATH}")

    def source_name(self, resolved: Path) -> str:
        """How a mesh file is named in :attr:`~spark_bench.asset.model.Visual.source`: relative to the object
        folder (confined) or to the URDF's folder (``../meshes/a.obj``), absolute on another drive."""
        base = self.folder if self.confined else self.urdf.parent
        try:
            return os.path.relpath(resolved, base)
        except ValueError:  # another drive (Windows)
            return str(resolved)


def resolver_for(urdf: Path, folder: Path | None, package_paths: Sequence[Path] | None) -> MeshPathResolver:
    """A :class:`MeshPathResolver` of ``urdf`` (see its parameters)."""
    return MeshPathResolver(Path(urdf).resolve(), None if folder is None else Path(folder).resolve(),
                            list(package_paths or []))
