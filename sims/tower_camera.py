"""A fixed depth camera over the tower cell: depth and segmentation images, back-projected to points.

The camera is pybullet's synthetic camera with the CPU renderer (``ER_TINY_RENDERER``, no GPU): one
call gives a colour image, the depth buffer and the segmentation buffer. The depth buffer holds the
renderer's normalised device depth; every pixel is turned into a 3-D point in the world frame with
the inverse of the camera's projection and view matrices (the very matrices the renderer used), so
no intrinsics are re-derived by hand. The segmentation buffer separates objects the way a colour or
instance segmenter would on a real robot: it says which pixels belong to which object and nothing
else (no pose, no size, no shape).

The sensor model is that of a structured-light camera (Kinect-like): with ``depth_noise`` the depth
of each pixel gets Gaussian noise whose standard deviation grows with the square of the depth
(``depth_noise`` is the standard deviation at 1 m), applied along the pixel's viewing ray; with
``depth_dropout`` each pixel independently returns no depth with that probability. Both draw from
the camera's own Generator, never the one that draws motor noise. ``docs/perception.md`` documents
the camera's pose and intrinsics.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass

import numpy as np
import pybullet_data

from .tower_kinematics import pb

WIDTH, HEIGHT = 320, 240           # pixels
FOV_Y = 52.0                       # vertical field of view, degrees
NEAR, FAR = 0.3, 3.0               # clipping planes (m): nothing of the cell is nearer or farther
EYE = (1.10, 0.0, 0.80)            # camera position (m), in front of the table, opposite the arm
TARGET = (0.46, 0.0, 0.20)         # the point it looks at: above the middle of the start region
UP = (0.0, 0.0, 1.0)


@dataclass(frozen=True)
class Frame:
    """One capture: per-pixel world points (H x W x 3, NaN where there is no depth), the segment
    id of each pixel (body id; -1 for none) and the colour image (H x W x 3, for pictures)."""

    points: np.ndarray
    segment: np.ndarray
    rgb: np.ndarray
    depth: np.ndarray              # metric depth along the optical axis (m), NaN where missing


def view_matrix() -> np.ndarray:
    """World -> camera (OpenGL convention: the camera looks down its -z axis), 4 x 4."""
    return np.array(pb.computeViewMatrix(EYE, TARGET, UP)).reshape(4, 4).T


def projection_matrix(width: int = WIDTH, height: int = HEIGHT) -> np.ndarray:
    """Camera -> clip space, 4 x 4 (pinhole, vertical field of view FOV_Y, square pixels)."""
    return np.array(pb.computeProjectionMatrixFOV(FOV_Y, width / height, NEAR, FAR)).reshape(4, 4).T


def intrinsics(width: int = WIDTH, height: int = HEIGHT) -> dict[str, float]:
    """The pinhole intrinsics equivalent to :func:`projection_matrix` (pixels): focal lengths and
    principal point, for documentation and for checking the back-projection by hand."""
    f = height / 2 / np.tan(np.radians(FOV_Y) / 2)
    return {"fx": float(f), "fy": float(f), "cx": width / 2, "cy": height / 2}


def pixel_ndc(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Normalised device x and y of every pixel centre (row 0 at the top of the image)."""
    x = (np.arange(width) + 0.5) / width * 2 - 1
    y = 1 - (np.arange(height) + 0.5) / height * 2
    return np.meshgrid(x, y)


def back_project(depth_buffer: np.ndarray, proj: np.ndarray) -> np.ndarray:
    """Camera-frame points (H x W x 3) of a depth buffer (values in [0, 1], as the renderer
    writes them) through the inverse projection; pixels at the far plane (no surface) are NaN."""
    h, w = depth_buffer.shape
    x, y = pixel_ndc(w, h)
    ndc = np.stack([x, y, 2 * depth_buffer - 1, np.ones_like(x)], axis=-1)
    cam = ndc @ np.linalg.inv(proj).T
    cam = cam[..., :3] / cam[..., 3:]
    cam[depth_buffer >= 1.0 - 1e-7] = np.nan
    return cam


def to_world(cam: np.ndarray, view: np.ndarray) -> np.ndarray:
    """Camera-frame points (... x 3) in the world frame."""
    inv = np.linalg.inv(view)
    return cam @ inv[:3, :3].T + inv[:3, 3]


def corrupt(cam: np.ndarray, noise: float, dropout: float, rng: np.random.Generator | None) -> np.ndarray:
    """The structured-light sensor model on camera-frame points: depth noise with standard deviation
    ``noise * depth^2`` along each pixel's ray, and each pixel lost with probability ``dropout``."""
    if rng is None or (noise <= 0 and dropout <= 0):
        return cam
    out = cam.copy()
    depth = -out[..., 2]                                  # the camera looks down -z
    if noise > 0:
        eps = rng.normal(0.0, 1.0, depth.shape) * noise * depth ** 2
        out *= ((depth + eps) / depth)[..., None]         # move the point along its ray
    if dropout > 0:
        out[rng.random(depth.shape) < dropout] = np.nan
    return out


def coarse_arm_urdf(urdf: str) -> str:
    """A copy of the arm's URDF (in a temporary folder) whose links look like their collision meshes:
    the geometry the physics simulates, a few thousand triangles instead of the detailed visual
    meshes' hundreds of thousands (the CPU renderer's cost grows with the triangles)."""
    folder = os.path.dirname(os.path.join(pybullet_data.getDataPath(), urdf))
    with open(os.path.join(pybullet_data.getDataPath(), urdf)) as f:
        text = f.read()
    text = text.replace("package://meshes/visual/", "package://meshes/collision/")
    text = text.replace("package://meshes/", folder + "/meshes/")
    out = os.path.join(tempfile.mkdtemp(prefix="groundsym-camera-"), os.path.basename(urdf))
    with open(out, "w") as f:
        f.write(text)
    return out


class RenderTwin:
    """What the camera renders: a copy of a world's looks in a pybullet client of its own, the arm
    with its collision meshes as its looks, every other body with its own visual shape. Before each
    frame the copy takes the world's body poses and joint angles (a few dozen calls); segment ids
    are mapped back to the world's body ids. Objects are rendered exactly as in the world; only
    the arm's surface is coarser (its collision hull, a few mm outside the detailed mesh)."""

    def __init__(self, arm_urdf: str):
        self.client = pb.connect(pb.DIRECT)
        self.arm = pb.loadURDF(coarse_arm_urdf(arm_urdf), (0, 0, 0), useFixedBase=True, physicsClientId=self.client)
        self.joints = list(range(pb.getNumJoints(self.arm, physicsClientId=self.client)))
        self.pairs: list[tuple[int, int]] = []          # (world body, copy) of every body but the arm
        self.world = self.world_arm = -1
        self.to_world = np.zeros(0, dtype=np.int64)

    def watch(self, client: int, arm: int) -> None:
        """Copy the looks of every body of world ``client`` but ``arm`` (call after the world is
        rebuilt; the previous copies are removed)."""
        c = self.client
        for _, copy in self.pairs:
            pb.removeBody(copy, physicsClientId=c)
        self.pairs = []
        for k in range(pb.getNumBodies(physicsClientId=client)):
            uid = pb.getBodyUniqueId(k, physicsClientId=client)
            if uid == arm:
                continue
            v = pb.getVisualShapeData(uid, physicsClientId=client)[0]
            kind, dims, colour = v[2], v[3], v[7]
            frame = {"visualFramePosition": v[5], "visualFrameOrientation": v[6], "rgbaColor": colour,
                     "physicsClientId": c}
            if kind == pb.GEOM_BOX:
                shape = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[x / 2 for x in dims], **frame)
            elif kind == pb.GEOM_SPHERE:
                shape = pb.createVisualShape(pb.GEOM_SPHERE, radius=dims[0], **frame)
            elif kind == pb.GEOM_CYLINDER:
                shape = pb.createVisualShape(pb.GEOM_CYLINDER, length=dims[0], radius=dims[1], **frame)
            else:
                raise ValueError(f"body {uid}: the camera copies boxes, spheres and cylinders, not geometry {kind}")
            self.pairs.append((uid, pb.createMultiBody(0, -1, shape, physicsClientId=c)))
        ids = [(copy, uid) for uid, copy in self.pairs] + [(self.arm, arm)]
        self.to_world = np.full(max(i for i, _ in ids) + 2, -1, dtype=np.int64)
        for copy, uid in ids:
            self.to_world[copy] = uid
        self.world, self.world_arm = client, arm

    def sync(self) -> None:
        """The copy takes the world's current poses and joint angles (and copies the bodies again
        when the world has gained or lost some since)."""
        c, w = self.client, self.world
        if pb.getNumBodies(physicsClientId=w) != len(self.pairs) + 1:
            self.watch(w, self.world_arm)
        for uid, copy in self.pairs:
            pos, orn = pb.getBasePositionAndOrientation(uid, physicsClientId=w)
            pb.resetBasePositionAndOrientation(copy, pos, orn, physicsClientId=c)
        pos, orn = pb.getBasePositionAndOrientation(self.world_arm, physicsClientId=w)
        pb.resetBasePositionAndOrientation(self.arm, pos, orn, physicsClientId=c)
        for j, state in zip(self.joints, pb.getJointStates(self.world_arm, self.joints, physicsClientId=w)):
            pb.resetJointState(self.arm, j, state[0], physicsClientId=c)

    def segments(self, seg: np.ndarray) -> np.ndarray:
        """The copy's segment ids as the world's body ids (-1: none)."""
        return np.where(seg >= 0, self.to_world[np.clip(seg, 0, len(self.to_world) - 1)], -1)

    def close(self) -> None:
        if self.client >= 0:
            pb.disconnect(physicsClientId=self.client)
            self.client = -1


class DepthCamera:
    """The cell's camera; :meth:`capture` renders the current world of a pybullet client (with
    :meth:`watch`, through a :class:`RenderTwin` whose arm has coarser looks)."""

    def __init__(self, noise: float = 0.0, dropout: float = 0.0, width: int = WIDTH, height: int = HEIGHT):
        self.noise, self.dropout = noise, dropout
        self.width, self.height = width, height
        self.view = view_matrix()
        self.proj = projection_matrix(width, height)
        self.rng: np.random.Generator | None = None
        self.twin: RenderTwin | None = None

    def seed(self, rng: np.random.Generator) -> None:
        """The camera's own Generator (its noise never shifts the motor noise's draws)."""
        self.rng = rng

    def watch(self, client: int, arm: int, arm_urdf: str) -> None:
        """Render world ``client`` from now on through a copy whose arm ``arm`` (loaded from
        ``arm_urdf``, relative to pybullet_data) looks like its collision meshes; call again after
        the world is rebuilt."""
        if self.twin is None:
            self.twin = RenderTwin(arm_urdf)
        self.twin.watch(client, arm)

    def capture(self, client: int) -> Frame:
        """Render and back-project one frame (of the watched world's copy when ``client`` is it)."""
        w, h = self.width, self.height
        twin = self.twin if self.twin is not None and self.twin.world == client else None
        if twin is not None:
            twin.sync()
        _, _, rgb, depth_buf, seg = pb.getCameraImage(
            w, h, self.view.T.ravel().tolist(), self.proj.T.ravel().tolist(), renderer=pb.ER_TINY_RENDERER,
            lightDirection=(1.0, -0.6, 2.0), physicsClientId=client if twin is None else twin.client)
        depth_buf = np.asarray(depth_buf, dtype=float).reshape(h, w)
        seg = np.asarray(seg, dtype=np.int64).reshape(h, w)
        if twin is not None:
            seg = twin.segments(seg)
        cam = corrupt(back_project(depth_buf, self.proj), self.noise, self.dropout, self.rng)
        seg = np.where(np.isnan(cam[..., 2]), -1, seg)
        rgb_img = np.asarray(rgb, dtype=np.uint8).reshape(h, w, 4)[:, :, :3]
        return Frame(to_world(cam, self.view), seg, rgb_img, -cam[..., 2])

    def close(self) -> None:
        if self.twin is not None:
            self.twin.close()
            self.twin = None

    def clouds(self, frame: Frame, uids: list[int]) -> list[np.ndarray]:
        """Each body's visible points (N_i x 3, world frame), from the segmentation alone."""
        flat_seg = frame.segment.ravel()
        flat = frame.points.reshape(-1, 3)
        order = np.argsort(flat_seg, kind="stable")
        sorted_seg = flat_seg[order]
        out = []
        for uid in uids:
            lo, hi = np.searchsorted(sorted_seg, [uid, uid + 1])
            out.append(flat[order[lo:hi]])
        return out
