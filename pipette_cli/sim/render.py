"""Offscreen rendering of the three task cameras, with two render profiles.

``fast``: no shadows, no reflections, no multisampling and decimated visual meshes
(:mod:`.meshes`) — made for a CPU (llvmpipe). ``full``: shadows, reflections, 4x MSAA and the
original meshes, for figures and GPU machines. A profile's meshes are compiled into the model
(``World(task, meshes=PROFILES[p].meshes)``); the physics is the same under both.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

from pipette_cli.errors import SimError
from pipette_cli.sim.meshes import MeshDetail
from pipette_cli.sim.scene import CAMERA_NAMES, WRIST_CAMERA

Profile = Literal["fast", "full"]


@dataclass(frozen=True)
class RenderProfile:
    shadows: bool
    reflections: bool
    samples: int
    meshes: MeshDetail


PROFILES: dict[str, RenderProfile] = {
    "fast": RenderProfile(shadows=False, reflections=False, samples=0, meshes="decimated"),
    "full": RenderProfile(shadows=True, reflections=True, samples=4, meshes="full"),
}


def find_profile(name: str) -> RenderProfile:
    """The :class:`RenderProfile` called ``name``.

    Raises:
        SimError: unknown profile, with the known ones.
    """
    if name not in PROFILES:
        raise SimError(f"unknown render profile {name!r}; expected one of {', '.join(PROFILES)}")
    return PROFILES[name]


def camera_ids(model: mujoco.MjModel) -> dict[str, int]:
    """Model ids of the top, main and wrist cameras."""
    ids = {}
    for name in CAMERA_NAMES:
        full = WRIST_CAMERA if name == "wrist" else name
        index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, full)
        if index < 0:
            index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        if index < 0:
            raise SimError(f"scene has no camera {name!r}")
        ids[name] = index
    return ids


class CameraRig:
    """Renders the task's cameras into uint8 HxWx3 arrays."""

    def __init__(self, model: mujoco.MjModel, width: int, height: int, profile: Profile = "fast") -> None:
        self.profile = find_profile(profile)
        model.vis.quality.offsamples = self.profile.samples
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        try:
            self.renderer = mujoco.Renderer(model, height=height, width=width)
        except Exception as exc:
            raise SimError(
                f"cannot create an offscreen OpenGL context ({exc}); set MUJOCO_GL=egl (or osmesa) on headless machines"
            ) from None
        self.ids = camera_ids(model)
        self.width, self.height = width, height

    def _configure_scene(self) -> None:
        flags = self.renderer.scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self.profile.shadows
        flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = self.profile.reflections

    def render(self, data: mujoco.MjData, camera: str) -> np.ndarray:
        self.renderer.update_scene(data, camera=self.ids[camera])
        self._configure_scene()
        return self.renderer.render().copy()

    def render_all(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        return {name: self.render(data, name) for name in CAMERA_NAMES}

    def close(self) -> None:
        self.renderer.close()


def gl_info() -> dict[str, str]:
    """The OpenGL backend (``MUJOCO_GL``) and the vendor, renderer and version strings of the
    context current in this thread (after a render); ``unknown`` where there is none."""
    info = {"gl_backend": os.environ.get("MUJOCO_GL", "default")}
    try:
        from OpenGL import GL  # deferred: OpenGL.GL (~65 ms; read once per evaluation run)

        for key, name in (("gl_vendor", GL.GL_VENDOR), ("gl_renderer", GL.GL_RENDERER), ("gl_version", GL.GL_VERSION)):
            value = GL.glGetString(name)
            info[key] = value.decode(errors="replace") if value else "unknown"
    except Exception:  # no PyOpenGL, or no current context: the backend alone is still worth keeping
        info.update({k: "unknown" for k in ("gl_vendor", "gl_renderer", "gl_version") if k not in info})
    return info
