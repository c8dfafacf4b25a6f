"""The depth camera and the point-cloud features against independent truth: known bodies at known
poses (their surfaces by hand), the camera's pinhole model built by hand from its documented pose
and intrinsics, synthetic clouds with closed-form PCA, occlusion, and determinism per seed."""

from __future__ import annotations

import numpy as np
import pytest

from groundsym.cli import main
from groundsym.errors import UserError
from groundsym.logic import Atom
from groundsym.pointcloud import FEATURE_NAMES, MIN_POINTS, cloud_features, features_from_clouds
from groundsym.traces import read_traces, write_traces
from groundsym.collect import collect_traces
from sims.tower import TowerSim
from sims.tower_camera import EYE, HEIGHT, TARGET, UP, WIDTH, DepthCamera, intrinsics
from sims.tower_kinematics import pb


@pytest.fixture()
def client():
    """A bare pybullet world: only the bodies a test makes (visual shapes, no physics needed)."""
    c = pb.connect(pb.DIRECT)
    yield c
    pb.disconnect(physicsClientId=c)


def make_body(client: int, shape: str, size, pos, orn=(0, 0, 0, 1)) -> int:
    half = np.broadcast_to(np.asarray(size, dtype=float) / 2, (3,))
    if shape == "box":
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half.tolist(), physicsClientId=client)
    elif shape == "cylinder":                                       # as tall as wide, as the cell's cans
        vis = pb.createVisualShape(pb.GEOM_CYLINDER, radius=float(half[0]), length=float(2 * half[0]),
                                   physicsClientId=client)
    else:
        vis = pb.createVisualShape(pb.GEOM_SPHERE, radius=float(half[0]), physicsClientId=client)
    return pb.createMultiBody(0, -1, vis, pos, orn, physicsClientId=client)


def camera_frame() -> np.ndarray:
    """Rows: the camera's right, up and backward axes in the world, from its documented pose."""
    fwd = np.subtract(TARGET, EYE)
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, UP)
    right /= np.linalg.norm(right)
    return np.array([right, np.cross(right, fwd), -fwd])


def pinhole_pixels(points: np.ndarray) -> np.ndarray:
    """Image column and row of world points through the documented intrinsics (by hand)."""
    k = intrinsics()
    cam = (points - np.array(EYE)) @ camera_frame().T
    depth = -cam[:, 2]
    return np.column_stack([k["cx"] + k["fx"] * cam[:, 0] / depth, k["cy"] - k["fy"] * cam[:, 1] / depth])


def test_optical_axis_pixel_lands_where_the_axis_meets_a_plate(client):
    """The four centre pixels back-project to the point where the ray from the eye through the
    target meets a horizontal plate at height h (hand-computed)."""
    h = 0.05
    make_body(client, "box", (1.0, 1.0, 0.02), (0.5, 0.0, h - 0.01))
    frame = DepthCamera().capture(client)
    centre = frame.points[HEIGHT // 2 - 1:HEIGHT // 2 + 1, WIDTH // 2 - 1:WIDTH // 2 + 1].reshape(-1, 3).mean(0)
    eye, target = np.array(EYE), np.array(TARGET)
    want = eye + (eye[2] - h) / (eye[2] - target[2]) * (target - eye)
    np.testing.assert_allclose(centre, want, atol=0.002)


@pytest.mark.parametrize("shape", ["box", "sphere"])
def test_back_projected_points_lie_on_the_known_surface(client, shape):
    """Every point of a body at a known pose lies on its surface (box: the largest local coordinate
    is the half edge; sphere: the distance from the centre is the radius), and each point's pixel
    is the one the documented pinhole model puts it in."""
    pos = np.array([0.52, 0.08, 0.15])
    euler = (0.3, 0.2, 0.7) if shape == "box" else (0, 0, 0)
    uid = make_body(client, shape, 0.05, pos, pb.getQuaternionFromEuler(euler))
    cam = DepthCamera()
    frame = cam.capture(client)
    pts = cam.clouds(frame, [uid])[0]
    assert len(pts) > 100
    if shape == "box":
        rot = np.array(pb.getMatrixFromQuaternion(pb.getQuaternionFromEuler(euler))).reshape(3, 3)
        err = np.abs((pts - pos) @ rot).max(1) - 0.025
    else:
        err = np.linalg.norm(pts - pos, axis=1) - 0.025
    assert np.abs(err).max() < 0.004 and np.abs(err).mean() < 0.0015    # the renderer's facets and raster
    rows, cols = np.nonzero(frame.segment == uid)
    pix = pinhole_pixels(frame.points[rows, cols])
    assert np.abs(pix - np.column_stack([cols + 0.5, rows + 0.5])).max() < 0.01


def test_cloud_mean_of_a_cube_is_its_visible_surface_centroid(client):
    """The faces a camera sees are those facing it; with pixels spread evenly over the image, each
    contributes its centre weighted by its projected area (area * cos / distance^2)."""
    pos, edge, yaw = np.array([0.5, -0.1, 0.025]), 0.05, 0.4
    rot = np.array(pb.getMatrixFromQuaternion(pb.getQuaternionFromEuler((0, 0, yaw)))).reshape(3, 3)
    uid = make_body(client, "box", edge, pos, pb.getQuaternionFromEuler((0, 0, yaw)))
    cam = DepthCamera()
    pts = cam.clouds(cam.capture(client), [uid])[0]
    centres, weights = [], []
    for normal in np.vstack([rot.T, -rot.T]):
        c = pos + normal * edge / 2
        to_eye = np.array(EYE) - c
        cos = normal @ to_eye / np.linalg.norm(to_eye)
        if cos > 0 and c[2] > 0.001:         # facing the camera (the bottom face rests on the table)
            centres.append(c)
            weights.append(edge ** 2 * cos / (to_eye @ to_eye))
    want = np.average(centres, axis=0, weights=weights)
    assert np.linalg.norm(pts.mean(0) - want) < 0.003          # the renderer's depth is good to 1-2 mm
    assert np.linalg.norm(pts.mean(0) - pos) > 0.01            # ... and the cloud is not the cube's centre


def test_pca_and_sphere_fit_of_synthetic_clouds():
    """A flat 6 x 2 cm rectangle: spreads a / sqrt(12), b / sqrt(12), 0, a vertical third axis, and
    a sphere residual of millimetres; a sphere cap of radius 3 cm: residual 0, curvature 1 / 0.03."""
    rng = np.random.default_rng(0)
    u = rng.uniform(-0.5, 0.5, (4000, 2)) * [0.06, 0.02]
    plate = np.column_stack([u + [0.4, 0.1], np.full(len(u), 0.2)])
    f = dict(zip(FEATURE_NAMES, cloud_features(plate)))
    np.testing.assert_allclose([f["mean_x"], f["mean_y"], f["mean_z"]], [0.4, 0.1, 0.2], atol=1e-3)
    np.testing.assert_allclose([f["pca_sd1"], f["pca_sd2"]], [0.06 / np.sqrt(12), 0.02 / np.sqrt(12)], rtol=0.03)
    assert f["pca_sd3"] < 1e-9 and f["pca_axis3_z"] > 0.999 and f["pca_axis1_z"] < 1e-6
    # the algebraic fit of a flat patch is the circle about its centroid with r^2 = mean |p - mean|^2
    # (by symmetry), and the residual is the points' distance from that circle: no sphere fits a face
    flat = plate[:, :2] - plate[:, :2].mean(0)
    r = np.sqrt((flat ** 2).sum(1).mean())
    np.testing.assert_allclose(f["sphere_curvature"], 1 / r, rtol=0.02)
    np.testing.assert_allclose(f["sphere_rms"], np.sqrt(((np.linalg.norm(flat, axis=1) - r) ** 2).mean()), rtol=0.05)
    d = rng.normal(size=(3000, 3))
    d[:, 2] = np.abs(d[:, 2])                                   # the upper half: one view's cap
    cap = 0.03 * d / np.linalg.norm(d, axis=1, keepdims=True) + [0.5, 0.0, 0.1]
    f = dict(zip(FEATURE_NAMES, cloud_features(cap)))
    assert f["sphere_rms"] < 1e-9
    np.testing.assert_allclose(f["sphere_curvature"], 1 / 0.03, rtol=1e-6)
    with pytest.raises(ValueError):
        cloud_features(np.zeros((3, 3)))


def test_roundness_separates_balls_from_cubes_over_random_poses(client):
    """Over 30 random poses each (cubes turned any way, on or above the table), with depth noise
    and missing pixels, every ball's sphere residual is below every cube's."""
    rng = np.random.default_rng(3)
    cam = DepthCamera(noise=0.002, dropout=0.1)
    cam.seed(np.random.default_rng(4))
    rms = {"box": [], "sphere": []}
    for _ in range(30):
        for shape in rms:
            size = rng.choice([0.04, 0.05]) if shape == "box" else 0.045
            pos = [rng.uniform(0.35, 0.65), rng.uniform(-0.27, 0.27), rng.uniform(size / 2, 0.3)]
            q = rng.normal(size=4)
            uid = make_body(client, shape, size, pos, q / np.linalg.norm(q))
            pts = cam.clouds(cam.capture(client), [uid])[0]
            rms[shape].append(dict(zip(FEATURE_NAMES, cloud_features(pts)))["sphere_rms"])
            pb.removeBody(uid, physicsClientId=client)
    assert max(rms["sphere"]) < min(rms["box"])


def test_roundness_separates_balls_from_upright_cans(client):
    """A can shows a curved side and a flat top, which no sphere fits: over 30 random places on the
    table (any yaw), with depth noise and missing pixels, every ball's sphere residual is below
    every can's."""
    rng = np.random.default_rng(5)
    cam = DepthCamera(noise=0.002, dropout=0.1)
    cam.seed(np.random.default_rng(6))
    rms = {"cylinder": [], "sphere": []}
    for _ in range(30):
        for shape, size in (("cylinder", 0.042), ("sphere", 0.045)):
            pos = [rng.uniform(0.35, 0.65), rng.uniform(-0.27, 0.27), size / 2]
            uid = make_body(client, shape, size, pos, pb.getQuaternionFromEuler((0, 0, rng.uniform(-np.pi, np.pi))))
            pts = cam.clouds(cam.capture(client), [uid])[0]
            rms[shape].append(dict(zip(FEATURE_NAMES, cloud_features(pts)))["sphere_rms"])
            pb.removeBody(uid, physicsClientId=client)
    assert max(rms["sphere"]) < min(rms["cylinder"])


def test_cans_are_grasped_stacked_and_count_in_the_reward():
    """With the motor noise off, a can goes onto a cube and another can onto that can by the same
    two primitives as cubes; the reward is the mean lowest-point height over cubes and cans, here
    by hand from the sizes (a ball counts nothing)."""
    with TowerSim(cubes=1, big=0, balls=1, cans=2, noise=0) as sim:
        sim.reset(3)
        by = {shape: [o for o, (s, _) in zip(sim.objects, sim.kinds) if s == shape] for shape in ("cube", "can", "ball")}
        (cube,), (can1, can2), (ball,) = by["cube"], by["can"], by["ball"]
        for act in (("closeHandAround", can1), ("openHandOver", cube)):
            scene = sim.step(Atom(act[0], (act[1],)))
        assert Atom("on", (can1, cube)) in scene.truth
        assert scene.reward == pytest.approx(0.04 / 3, abs=0.002)
        sim.step(Atom("closeHandAround", (can2,)))
        scene = sim.step(Atom("openHandOver", (can1,)))
        assert {Atom("on", (can2, can1)), Atom("above", (can2, cube))} <= scene.truth
        assert scene.reward == pytest.approx((0.04 + 0.04 + 0.042) / 3, abs=0.003)
        assert Atom("ball", (ball,)) in scene.truth and not any(a.args[0] in (can1, can2) for a in scene.truth
                                                                   if a.predicate == "ball")


def test_lowest_point_of_a_tilted_can_and_cube():
    """A can (as tall as wide) tilted by t about x reaches down h/2 cos t + r sin t; a cube turned by
    t about x reaches down half an edge times (cos t + sin t): both by hand."""
    from sims.tower import lowest_points

    for t in (0.0, 0.3, np.pi / 4, 1.2, np.pi / 2):
        q = np.array([pb.getQuaternionFromEuler((t, 0, 0.7))])
        pos = np.array([[0.5, 0.0, 0.1]])
        got = lowest_points(pos, q, np.array([0.042]), ["can"])[0]
        assert got == pytest.approx(0.1 - 0.021 * (np.cos(t) + np.sin(t)), abs=1e-9)
        q = np.array([pb.getQuaternionFromEuler((t, 0, 0))])
        got = lowest_points(pos, q, np.array([0.05]), ["cube"])[0]
        assert got == pytest.approx(0.1 - 0.025 * (abs(np.cos(t)) + abs(np.sin(t))), abs=1e-9)
        assert lowest_points(pos, q, np.array([0.045]), ["ball"])[0] == pytest.approx(0.1 - 0.0225)


def test_objects_without_enough_points_keep_their_last_features():
    clouds = [np.random.default_rng(0).normal(size=(MIN_POINTS, 3)), np.zeros((MIN_POINTS - 1, 3))]
    last = np.arange(20.0).reshape(2, 10)
    feats, seen = features_from_clouds(clouds, last)
    assert seen.tolist() == [True, False]
    np.testing.assert_array_equal(feats[1], last[1])
    np.testing.assert_allclose(feats[0], cloud_features(clouds[0]))
    feats, seen = features_from_clouds(clouds, None)               # never seen: zeros, flagged
    assert not feats[1].any() and not seen[1]


@pytest.fixture(scope="module")
def seeing():
    sim = TowerSim(cubes=3, big=1, balls=2, noise=0, features="pointcloud")
    yield sim
    sim.close()


def test_the_cell_sees_every_object_at_the_start(seeing):
    for seed in range(6):
        scene = seeing.reset(seed)
        assert scene.unseen == ()
        pos, _ = seeing.world.poses()
        assert np.abs(scene.features[:, :2] - pos[:, :2]).max() < 0.02     # the clouds are where the objects are
        np.testing.assert_array_equal(scene.pairs(), scene.features[:, None, :3] - scene.features[None, :, :3])


def test_the_render_copy_shows_every_object_as_the_world_itself_does():
    """The camera renders a copy of the world whose arm looks like its collision meshes: every
    object not in the hand gets exactly the points a render of the world itself gives, before and
    after a grasp; the arm covers about as many pixels (its hull is a little larger)."""
    with TowerSim(cubes=2, big=1, balls=1, cans=1, noise=0, features="pointcloud") as sim:
        sim.reset(1)
        direct = DepthCamera()
        uids = [b.uid for b in sim.world.bodies]
        for act in (None, Atom("closeHandAround", (sim.objects[0],))):
            if act is not None:
                sim.step(act)
            seen, truth = sim.camera.capture(sim.world.client), direct.capture(sim.world.client)
            held = sim.world.held
            for k, (a, b) in enumerate(zip(sim.camera.clouds(seen, uids), direct.clouds(truth, uids))):
                if k != held:
                    np.testing.assert_array_equal(a, b)
            arm = [(f.segment == sim.world.robot).sum() for f in (seen, truth)]
            assert 0.9 < arm[0] / arm[1] < 1.15
        assert held == 0


def test_a_fully_occluded_object_is_unseen_and_keeps_its_last_features(seeing):
    """A plate between the camera and object k hides it; moving k behind the plate changes nothing
    of what is seen (its features are never read from the simulator), the others stay seen."""
    before = seeing.reset(2)
    k = 1
    w = seeing.world
    centre = np.array(pb.getBasePositionAndOrientation(w.bodies[k].uid, physicsClientId=w.client)[0])
    to_eye = (np.array(EYE) - centre) / np.linalg.norm(np.array(EYE) - centre)
    plate = make_body(w.client, "box", 0.07, centre + 0.2 * to_eye)
    pb.resetBasePositionAndOrientation(w.bodies[k].uid, centre + [0.0, 0.0, 0.01], (0, 0, 0, 1),
                                       physicsClientId=w.client)
    after = seeing.scene()
    pb.removeBody(plate, physicsClientId=w.client)
    assert after.unseen == (seeing.objects[k],)
    np.testing.assert_array_equal(after.features[k], before.features[k])
    others = [i for i in range(len(seeing.objects)) if i != k]
    np.testing.assert_allclose(after.features[others, :3], before.features[others, :3], atol=0.002)
    again = seeing.scene()                                          # the plate gone: seen where it now is
    assert again.unseen == () and again.features[k, 2] > before.features[k, 2] + 0.005


def test_same_seed_same_clouds_and_the_camera_does_not_shift_motor_noise():
    """Depth noise and dropout repeat per seed, differ across seeds, and draw from their own
    stream: the arm's motions (poses, truth) equal those of the pose cell with the same seed."""
    act = Atom("closeHandAround", ("o2",))
    opts = dict(cubes=2, big=1, balls=1)
    with TowerSim(**opts, features="pointcloud", depth_noise=0.003, depth_dropout=0.2) as a, \
            TowerSim(**opts) as pose:
        a1, p1 = a.reset(5), pose.reset(5)
        a2, p2 = a.step(act), pose.step(act)
        np.testing.assert_array_equal(a.world.poses()[0], p2.features[:, :3])
        assert a2.truth == p2.truth and a1.truth == p1.truth
        b1 = a.reset(5)
        np.testing.assert_array_equal(b1.features, a1.features)
        c1 = a.reset(6)
        assert not np.array_equal(c1.features, a1.features)


def test_feature_space_options(tmp_path):
    assert TowerSim.features_for({}) == ("x", "y", "z", "size")
    assert TowerSim.features_for({"features": "pointcloud"}) == FEATURE_NAMES
    with pytest.raises(UserError, match="features=depth: unknown feature space"):
        TowerSim(features="depth")
    with pytest.raises(UserError, match="depth_noise=0.01: the depth camera is used with features=pointcloud"):
        TowerSim(depth_noise=0.01)
    with pytest.raises(UserError, match="depth_dropout=1.0"):
        TowerSim(features="pointcloud", depth_dropout=1.0)
    with TowerSim() as sim:                     # pose traces record the options they always did
        assert sim.options == {"cubes": 7, "big": 3, "balls": 0, "noise": 0.0075, "small_size": 0.04,
                               "big_size": 0.05, "ball_size": 0.045}
    with pytest.raises(UserError, match="can_size=0.04: cans need a size distinct"):
        TowerSim(cubes=1, cans=1, can_size=0.04)
    with pytest.raises(UserError, match="at most 10 objects"):
        TowerSim(cubes=5, balls=3, cans=3)
    assert TowerSim.features_for({"cans": 2, "features": "pointcloud"}) == FEATURE_NAMES


def test_pointcloud_traces_round_trip_with_unseen_flags_and_mean_pairs(tmp_path):
    with TowerSim(cubes=1, balls=1, noise=0, features="pointcloud") as sim:
        ds = collect_traces(sim, 1, 1, 0, progress=False)
    scene = ds.traces[0].scenes[0]
    object.__setattr__(scene, "unseen", ("o2",))
    write_traces(tmp_path / "t.json", ds)
    back = read_traces(tmp_path / "t.json")
    assert back.feature_names == FEATURE_NAMES and back.meta["options"]["features"] == "pointcloud"
    assert back.meta["pair_feature_names"] == ["dmean_x", "dmean_y", "dmean_z"]
    got = back.traces[0].scenes
    assert got[0].unseen == ("o2",) and got[1].unseen == ()
    np.testing.assert_array_equal(got[1].pairs(), ds.traces[0].scenes[1].pairs())


def test_cli_refuses_unknown_feature_spaces_and_mixed_ones(tmp_path, capsys):
    assert main(["collect", "--sim", "tower", "--sim-opt", "features=kinect", "--traces", "1", "--length", "1",
                 "-o", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "features=kinect: unknown feature space" in err[0]
    for name, opt in (("pc.json", "cubes=1 balls=1 noise=0 features=pointcloud"), ("pose.json", "cubes=1 balls=1")):
        assert main(["collect", "--sim", "tower", "--sim-opt", opt, "--traces", "1", "--length", "2",
                     "--seed", "1", "-o", str(tmp_path / name), "--quiet"]) == 0
    pose = str(tmp_path / "pose.json")
    assert main(["learn", str(tmp_path / "pc.json"), "--model-data", pose, "-o",
                 str(tmp_path / "m"), "--evals", "50", "--restarts", "1", "--workers", "1", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "feature space" in err[0] and not (tmp_path / "m").exists()
    assert main(["learn", pose, "-o", str(tmp_path / "pm"), "--evals", "50",
                 "--restarts", "1", "--workers", "1", "--quiet"]) == 0
    capsys.readouterr()
    assert main(["show", str(tmp_path / "pm"), "--against", str(tmp_path / "pc.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "do not match the symbols' feature space" in err[0]
    assert main(["plan", "--sim", "tower", "--sim-opt", "cubes=1 balls=1", "--model", str(tmp_path / "pm"),
                 "--sim-opt", "features=pointcloud", "--steps", "1"]) == 2        # checked before the physics
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'pca_sd1'" in err[0] and "'size'" in err[0]
