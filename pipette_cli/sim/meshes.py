"""Decimated visual meshes for the ``fast`` render profile, cached on disk.

On a software renderer (Mesa llvmpipe) a capture costs what its triangles cost: the Panda's
visual meshes are 135k of a scene's 137k. :func:`decimate_visual_meshes` points, in a composed
scene spec, every geom that only the renderer sees at a quadric-error simplification of its
mesh (``fast-simplification``, the Fast-Quadric-Mesh-Simplification algorithm) keeping
:attr:`Decimation.keep` of the triangles. A geom qualifies when it collides with nothing
(``contype = conaffinity = 0``) and its body's inertia is given explicitly; collision geoms and
primitives fitted to a mesh keep the original, so the physics (collision meshes, masses,
inertias) is exactly that of the full model. Textured meshes are left alone (simplification
would lose their texture coordinates).

Simplified meshes are cached under :func:`cache_dir`, one ``.npz`` per source mesh, keyed by
the SHA-256 of the mesh as MuJoCo loaded it (vertices and faces) and the simplification
settings; the first scene build on a machine pays about 0.1 s per heavy mesh, later builds
load the cache.
"""

from __future__ import annotations

import hashlib
import logging
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import fast_simplification
import mujoco
import numpy as np

log = logging.getLogger(__name__)

MeshDetail = Literal["full", "decimated"]
CACHE_ENV = "PIPETTE_MESH_CACHE"
"""Environment variable naming the cache folder (default: the user cache, see :func:`cache_dir`)."""
CACHE_FORMAT = 3


@dataclass(frozen=True)
class Decimation:
    """How far visual meshes are simplified.

    Attributes:
        keep: Fraction of a mesh's triangles kept ...
        min_faces: ... but never fewer than this many.
        heavy: Meshes with at most this many triangles are left as they are.
    """

    keep: float = 0.08
    min_faces: int = 400
    heavy: int = 1000

    def target(self, faces: int) -> int:
        return max(round(self.keep * faces), self.min_faces)

    def key(self) -> str:
        return f"v{CACHE_FORMAT}-keep{self.keep:g}-min{self.min_faces}"  # ``heavy`` only selects meshes


FAST = Decimation()


def cache_dir() -> Path:
    """``$PIPETTE_MESH_CACHE``, else ``$XDG_CACHE_HOME/pipette/meshes`` (``~/.cache/pipette/meshes``)."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "pipette" / "meshes"


def mesh_arrays(model: mujoco.MjModel, mesh: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (in MuJoCo's centred mesh frame) and triangles of mesh ``mesh``."""
    v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
    f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
    return model.mesh_vert[v0 : v0 + nv], model.mesh_face[f0 : f0 + nf]


def weld(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge vertices at the same position (MuJoCo splits them where normals or texture
    coordinates differ); without this every seam is an open border the simplifier tears."""
    unique, inverse = np.unique(vertices, axis=0, return_inverse=True)
    welded = inverse.reshape(-1)[faces]
    keep = (welded[:, 0] != welded[:, 1]) & (welded[:, 1] != welded[:, 2]) & (welded[:, 0] != welded[:, 2])
    return unique, welded[keep].astype(np.int32)


def simplify(vertices: np.ndarray, faces: np.ndarray, decimation: Decimation = FAST) -> tuple[np.ndarray, np.ndarray]:
    """``vertices``/``faces`` simplified to about ``decimation.keep`` of the faces, from the cache
    when this exact mesh was simplified before with the same settings."""
    vertices = np.ascontiguousarray(vertices, dtype=np.float32)
    faces = np.ascontiguousarray(faces, dtype=np.int32)
    digest = hashlib.sha256(vertices.tobytes() + faces.tobytes()).hexdigest()
    path = cache_dir() / f"{digest}-{decimation.key()}.npz"
    try:
        with np.load(path) as cached:
            return cached["vertices"], cached["faces"]
    except (OSError, KeyError, ValueError):
        pass

    points, triangles = weld(vertices, faces)
    reduction = 1.0 - decimation.target(len(triangles)) / len(triangles)
    points, triangles = fast_simplification.simplify(points, triangles, target_reduction=max(reduction, 0.0))
    points, triangles = np.asarray(points, dtype=np.float32), np.asarray(triangles, dtype=np.int32)
    _store(path, points, triangles)
    return points, triangles


def _store(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Write atomically (tmp + rename) so concurrent workers never read half a file."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".npz.tmp")
        with os.fdopen(fd, "wb") as f:
            np.savez(f, vertices=vertices, faces=faces)
        os.replace(tmp, path)
    except OSError as exc:  # a read-only home still renders, just without the cache
        log.warning(
            "cannot cache a simplified mesh in %s (%s); set %s to a writable folder", path.parent, exc, CACHE_ENV
        )


SUFFIX = "/decimated"
"""Name of a mesh's simplified copy: ``<mesh>/decimated``."""


def _mass_from_geoms(spec: mujoco.MjSpec, geom: mujoco.MjsGeom) -> bool:
    """Whether the geom's body takes its mass and inertia from its geoms."""
    body = geom.parent
    if body is None or body.name == spec.worldbody.name:
        return False
    if spec.compiler.inertiafromgeom == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE:
        return True
    return not body.explicitinertial


def visual_geoms(
    spec: mujoco.MjSpec, model: mujoco.MjModel, decimation: Decimation = FAST
) -> dict[str, list[mujoco.MjsGeom]]:
    """Heavy, untextured meshes (by name) with the spec geoms that only render them (see the module doc).

    A geom qualifies when it is a mesh geom, collides with nothing (``contype = conaffinity = 0``)
    and its body's inertia does not come from its geoms. Collision geoms and primitives fitted to
    a mesh keep the original.
    """
    chosen: dict[str, list[mujoco.MjsGeom]] = {}
    for geom in spec.geoms:
        if geom.type != mujoco.mjtGeom.mjGEOM_MESH or not geom.meshname or geom.meshname.endswith(SUFFIX):
            continue
        if geom.contype or geom.conaffinity or _mass_from_geoms(spec, geom):
            continue
        mesh = model.mesh(geom.meshname).id
        if model.mesh_facenum[mesh] <= decimation.heavy or model.mesh_texcoordnum[mesh] > 0:
            continue
        chosen.setdefault(geom.meshname, []).append(geom)
    return chosen


def decimate_visual_meshes(spec: mujoco.MjSpec, model: mujoco.MjModel, decimation: Decimation = FAST) -> int:
    """Point the geoms of :func:`visual_geoms` at simplified copies of their meshes, added to ``spec``.

    ``model`` is ``spec`` compiled: it gives each mesh as MuJoCo loaded it (scaled, centred at
    ``mesh_pos``/``mesh_quat``). The simplified vertices go back into the mesh's own frame, so a
    geom lands where it did. The original meshes stay in the spec (collision geoms and fitted
    primitives still use them; ids do not move). Returns how many meshes were simplified;
    ``spec`` must be compiled again for them to take effect.
    """
    chosen = visual_geoms(spec, model, decimation)
    before = after = 0
    for name, geoms in chosen.items():
        mesh = model.mesh(name).id
        vertices, faces = mesh_arrays(model, mesh)
        points, triangles = simplify(vertices, faces, decimation)
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, model.mesh_quat[mesh])
        local = points.astype(np.float64) @ rot.reshape(3, 3).T + model.mesh_pos[mesh]
        copy = spec.mesh(name + SUFFIX) or spec.add_mesh(
            name=name + SUFFIX,
            material=spec.mesh(name).material,
            uservert=local.ravel().tolist(),
            userface=triangles.ravel().tolist(),
            inertia=mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL,  # a simplified mesh need not be watertight
        )
        for geom in geoms:
            geom.meshname = copy.name
        before += len(faces)
        after += len(triangles)
    if chosen:
        log.debug("decimated %d visual meshes: %d -> %d triangles", len(chosen), before, after)
    return len(chosen)
