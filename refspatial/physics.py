"""Settling: drop the composed objects onto the table and keep only stable scenes.

Objects start a few millimetres above their support in their resting pose; after
``settle_s`` of simulation every one must be on the table, upright within
``max_tilt_deg``, close to where it was placed and (nearly) at rest. Anything
else rejects the scene with a reason slug that the run statistics count.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from .assets import MaterialSpec
from .compose import SceneRejected
from .mjcf import SpecOptions, body_name, build_spec
from .recipe import Recipe
from .scene import PlacedObject, Pose, Scene, quat_to_matrix

CHECK_EVERY_S = 0.05
MIN_SETTLE_S = 0.3
AT_REST = 1e-3  # every joint velocity below 1 mm/s (or 1 mrad/s)


def settle(scene: Scene, materials: dict[str, MaterialSpec], recipe: Recipe) -> Scene:
    """The scene with objects at their settled poses, or SceneRejected."""
    import mujoco

    spec_p = recipe["physics"]
    spec = build_spec(scene, materials, SpecOptions(dynamic=True, timestep_s=spec_p["timestep_s"], visual=False))
    # MuJoCo's sleeping: an island of touching bodies that has stayed below sleep_tolerance (1 mm/s,
    # AT_REST's own bound) is frozen until something wakes it. Bodies that landed first then cost
    # nothing while the rest settle: a third of the settle's time on every recipe, with the same
    # scenes rejected, the same contacts and poses within 0.6 mm (BENCHMARKS.md, thirteenth session).
    spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    try:
        model = spec.compile()
    except ValueError as exc:
        raise SceneRejected("model_error", str(exc).splitlines()[0]) from None
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    steps = int(round(spec_p["settle_s"] / model.opt.timestep))
    check = max(1, int(round(CHECK_EVERY_S / model.opt.timestep)))
    step = 0
    while step < steps:
        # MuJoCo runs the steps between two checks in one call (the same steps as one by one).
        n = min(check, steps - step)
        mujoco.mj_step(model, data, nstep=n)
        step += n
        if step % check == 0:
            if not np.all(np.isfinite(data.qpos)):
                raise SceneRejected("unstable_simulation", "non-finite state")
            # At rest well inside the capture limits: the rest of settle_s would change nothing.
            if step * model.opt.timestep >= MIN_SETTLE_S and np.abs(data.qvel).max() < AT_REST:
                break
    # Asleep, an island's contacts are not refreshed; every check below reads the state awake.
    model.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    mujoco.mj_forward(model, data)
    settled = tuple(_settled_object(model, data, obj) for obj in scene.objects)
    _check(scene, settled, model, data, spec_p)
    return dataclasses.replace(scene, objects=settled, contacts=contact_pairs(model, data, len(scene.objects)))


def contact_pairs(model, data, n_objects: int) -> tuple[tuple[int, int], ...]:
    """Object pairs touching in the settled state (physics' own contacts), -1 standing for the table."""
    from .mjcf import object_of_geom

    owner = object_of_geom(model, n_objects)
    owner[model.geom("table").id] = -1
    n = data.ncon
    contacts = data.contact
    a, b = owner[contacts.geom1[:n]], owner[contacts.geom2[:n]]
    touching = (a != b) & (np.maximum(a, b) >= 0) & (contacts.dist[:n] < 0.002)
    low, high = np.minimum(a, b)[touching].tolist(), np.maximum(a, b)[touching].tolist()
    return tuple(sorted(set(zip(low, high))))


def _settled_object(model, data, obj: PlacedObject) -> PlacedObject:
    b = model.body(body_name(obj.object_id)).id
    pos = tuple(float(v) for v in data.xpos[b])
    quat = tuple(float(v) for v in data.xquat[b])
    if quat[0] < 0:  # one sign convention, so equal poses are equal records
        quat = tuple(-q for q in quat)
    return dataclasses.replace(obj, pose=Pose(pos, quat))


def _check(before: Scene, after: tuple[PlacedObject, ...], model, data, spec_p: dict) -> None:
    import mujoco

    top = before.table.top_z_m
    max_cos = np.cos(np.radians(spec_p["max_tilt_deg"]))
    for old, new in zip(before.objects, after):
        name = f"{new.asset.name} (object {new.object_id})"
        if new.pose.pos_world_m[2] < top - 0.02:
            raise SceneRejected("fell_off_table", name)
        up = quat_to_matrix(new.pose.quat_wxyz)[:, 2]
        if up[2] < max_cos:
            raise SceneRejected("tipped_over", f"{name} tilted {np.degrees(np.arccos(np.clip(up[2], -1, 1))):.0f} deg")
        shift = np.linalg.norm(np.subtract(new.pose.pos_world_m[:2], old.pose.pos_world_m[:2]))
        if shift > spec_p["max_shift_m"]:
            raise SceneRejected("drifted", f"{name} moved {shift * 100:.1f} cm")
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, model.body(body_name(new.object_id)).id, vel, 0)
        if np.linalg.norm(vel[3:]) > spec_p["max_speed_m_s"]:
            raise SceneRejected("still_moving", f"{name} at {np.linalg.norm(vel[3:]):.3f} m/s")


def write_mjcf(scene: Scene, materials: dict[str, MaterialSpec], out_xml: Path) -> Path:
    """Write a settled scene as a self-contained MJCF file with its meshes beside it.

    The bodies keep their free joints and sit at their settled poses, so the file
    opens at rest in MuJoCo's viewer and can be simulated further.
    """
    out_xml = Path(out_xml)
    mesh_dir = out_xml.parent / f"{out_xml.stem}_meshes"
    mesh_dir.mkdir(parents=True, exist_ok=True)
    spec = build_spec(scene, materials, SpecOptions(dynamic=True, mesh_dir=mesh_dir))
    spec.meshdir = mesh_dir.name
    spec.texturedir = mesh_dir.name
    spec.modelfiledir = str(out_xml.parent)
    spec.compile()
    xml = spec.to_xml()
    tmp = out_xml.with_name(f".{out_xml.name}.partial")
    tmp.write_text(xml, encoding="utf-8")
    tmp.replace(out_xml)
    return out_xml
