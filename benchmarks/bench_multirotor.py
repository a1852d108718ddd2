"""Validate the multirotor (``replay/flight/multirotor/model.py``) against rotorpy's ``Multirotor``, an
independent model (Folk et al., University of Pennsylvania): the same parameters in both, the
same figures measured on both.

Run: ``.venv/bin/python benchmarks/bench_multirotor.py [--no-record]``
(needs the optional extra: ``.venv/bin/pip install -e '.[validate]'``, i.e. ``pip install rotorpy``).

The ``quadrotor`` preset goes into rotorpy as its parameter dictionary: mass, inertia, the hubs
(our FRD body axes turned to its FLU), spin directions (its yaw torque is about +z up, ours about
+z down: its direction = -ours), k_eta = k_f, k_m, rotor drag k_d, parasitic drag c_D, rotor
limits; its induced-inflow, translational-lift and flapping terms off (we have none). rotorpy has
one rotor time constant: both sides fly with tau = 12.5 ms (our preset has 25 ms slowing down).
rotorpy keeps the air density constant and we use the standard atmosphere's: everything flies at
0 m AMSL, where the two agree. rotorpy integrates with scipy's RK45 (tolerances 1e-9 / 1e-12 here),
we with RK4 at 100 Hz. Frames: rotorpy's world is z up (taken as ENU), ours NED.

Figures:

- **hover**: the rotor speed that carries the weight, ours (sqrt(m g / (4 k_f))) and rotorpy's
  (bisection on its body wrench's vertical force at rest);
- **open loop**: from hover, rotor 0 commanded 5 % faster for 0.3 s, then the hover speed, 1 s
  flown with the commands held by both models; the largest difference in attitude and position;
- **closed loop**: our controller (``MultirotorStack.control``, every 10 ms) flying rotorpy's model
  and ours: a 20 m step at 5 and at 12 m/s (overshoot, time to within 2 %), and 200 m at 12 m/s
  (top speed flown);
- **top speed** at the 45 deg tilt limit: level flight where the tilted thrust carries the weight
  and balances the drag, with each model's forces.

Results (2 cores, 13 s; ``--no-record``): hover 441.684 rad/s on both (7e-9 apart: the ISA
density at 0 m against rotorpy's 1.225 constant); open loop 0.0009 deg and 0.018 mm apart after
1 s (the vehicle has pitched 60 deg by then); 20 m step at 5 m/s: -0.05 % (no overshoot), 4.94 s
on both, the two flights 0.17 mm apart; at 12 m/s: -0.04 %, 3.78 s, 0.34 mm; 200 m at 12 m/s:
12.01 m/s on both; top speed at 45 deg: 23.72 m/s with either model's forces. Before the
H-force was applied at each hub with the hub's own airspeed (rotorpy's form) the open-loop yaw
differed by 0.7 deg after 1 s.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._record import emit
from replay.flight.multirotor import kernels as kern
from replay.flight.multirotor.model import (
    QUADROTOR,
    SPIN,
    MultirotorParams,
    hover_state,
    level_speed,
    top_speed,
)
from replay.flight.multirotor.stack import MultirotorStack
from replay.frames import rotation_body_to_ned
from replay.guidance import GoTo

DT = 0.01
P = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # NED <-> ENU
D = np.diag([1.0, -1.0, -1.0])  # FRD <-> FLU


def _rotorpy() -> Any:
    try:
        from rotorpy.vehicles.multirotor import Multirotor
    except ImportError:
        sys.exit("bench_multirotor needs rotorpy: .venv/bin/pip install -e '.[validate]'")
    return Multirotor


def quad_params(p: MultirotorParams) -> dict[str, Any]:
    """Our parameters as rotorpy's dictionary (FLU hubs, its spin sign)."""
    r = p.rotor_positions()
    return {
        "mass": p.mass,
        "Ixx": p.Jx,
        "Iyy": p.Jy,
        "Izz": p.Jz,
        "Ixy": 0.0,
        "Iyz": 0.0,
        "Ixz": 0.0,
        "num_rotors": 4,
        "rotor_pos": {f"r{i + 1}": np.array([r[i, 0], -r[i, 1], 0.0]) for i in range(4)},
        "rotor_directions": -np.asarray(SPIN),
        "rI": np.zeros(3),
        "c_Dx": p.drag_x,
        "c_Dy": p.drag_y,
        "c_Dz": p.drag_z,
        "k_eta": p.k_f,
        "k_m": p.k_m,
        "k_d": p.rotor_drag,
        "k_z": 0.0,
        "k_h": 0.0,
        "k_flap": 0.0,
        "tau_m": p.rotor_tau_up,
        "rotor_speed_min": p.rotor_speed_min,
        "rotor_speed_max": p.rotor_speed_max,
        "motor_noise_std": 0.0,
    }


def to_rotorpy(x: np.ndarray) -> dict[str, np.ndarray]:
    from scipy.spatial.transform import Rotation

    r_ned = rotation_body_to_ned(x[6], x[7], x[8])
    r_rp = P @ r_ned @ D
    return {
        "x": P @ x[0:3],
        "v": P @ (r_ned @ x[3:6]),
        "q": Rotation.from_matrix(r_rp).as_quat(),
        "w": D @ x[9:12],
        "wind": np.zeros(3),
        "rotor_speeds": np.array(x[12:16], dtype=float),
    }


def from_rotorpy(s: dict[str, np.ndarray]) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    r_ned = P @ Rotation.from_quat(s["q"]).as_matrix() @ D
    x = np.zeros(16)
    x[0:3] = P @ s["x"]
    x[3:6] = r_ned.T @ (P @ s["v"])
    x[6] = math.atan2(r_ned[2, 1], r_ned[2, 2])
    x[7] = -math.asin(max(-1.0, min(1.0, r_ned[2, 0])))
    x[8] = math.atan2(r_ned[1, 0], r_ned[0, 0])
    x[9:12] = D @ s["w"]
    x[12:16] = s["rotor_speeds"]
    return x


def rotorpy_model(p: MultirotorParams) -> Any:
    return _rotorpy()(
        quad_params(p),
        control_abstraction="cmd_motor_speeds",
        aero=True,
        integrator_kwargs={"method": "RK45", "rtol": 1e-9, "atol": 1e-12},
    )


def rotorpy_hover(p: MultirotorParams) -> float:
    """The rotor speed at which rotorpy's wrench at rest carries the weight (bisection)."""
    m = rotorpy_model(p)
    lo, hi = 0.0, p.rotor_speed_max
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        f, _ = m.compute_body_wrench(np.zeros(3), np.full(4, mid), np.zeros(3))
        lo, hi = (mid, hi) if f[2] < p.weight else (lo, mid)
    return 0.5 * (lo + hi)


def rotorpy_top_speed(p: MultirotorParams) -> float:
    """Level speed at the tilt limit with rotorpy's forces (the bisections of
    :func:`replay.flight.multirotor.model.level_speed`)."""
    m = rotorpy_model(p)
    tilt = math.radians(p.tilt_max_deg)

    def force_ned(v: float, w: float) -> np.ndarray:
        x = np.zeros(16)
        x[7] = -tilt
        r = rotation_body_to_ned(0.0, -tilt, 0.0)
        x[3:6] = r.T @ np.array([v, 0.0, 0.0])
        s = to_rotorpy(x)
        r_rp = P @ r @ D
        body_air = r_rp.T @ s["v"]
        f, _ = m.compute_body_wrench(np.zeros(3), np.full(4, w), body_air)
        return np.asarray(P @ (r_rp @ f) + np.array([0.0, 0.0, p.weight]))

    return level_speed(force_ned, p.rotor_speed_max)


def open_loop(p: MultirotorParams) -> tuple[float, float]:
    """(largest attitude difference deg, largest position difference m) over 1 s of the same
    rotor commands from hover: rotor 0 5 % faster for 0.3 s."""
    m = rotorpy_model(p)
    x = hover_state(p, [0.0, 0.0, 0.0])
    s = to_rotorpy(x)
    pk = p.pack()
    w0 = x[12]
    att = pos = 0.0
    for k in range(100):
        wc = np.full(4, w0)
        if k < 30:
            wc[0] *= 1.05
        x = kern.rk4(x, wc, DT, pk)
        s = m.step(s, {"cmd_motor_speeds": wc}, DT)
        y = from_rotorpy(s)
        att = max(att, float(np.degrees(np.abs(x[6:9] - y[6:9]).max())))
        pos = max(pos, float(np.abs(x[0:3] - y[0:3]).max()))
    return att, pos


def closed_loop(
    p: MultirotorParams, target: tuple[float, float, float], speed: float, duration: float
) -> dict[str, dict[str, float]]:
    """Our controller flying our model and rotorpy's: overshoot (%), time to within 2 % (s) and
    top speed (m/s) of a go-to from hover at the origin, and how far apart the two flights come
    (m, ``rotorpy.apart``)."""
    out: dict[str, dict[str, float]] = {}
    paths: list[np.ndarray] = []
    goal = np.array(target)
    length = float(np.linalg.norm(goal))
    for side in ("ours", "rotorpy"):
        st = MultirotorStack(p, [[0.0, 0.0, 0.0]] * 2, speed=speed)
        st.initial_state()
        st.apply(GoTo(target))
        x = hover_state(p, [0.0, 0.0, 0.0])
        m = rotorpy_model(p) if side == "rotorpy" else None
        s = to_rotorpy(x) if m is not None else None
        pk = p.pack()
        pos, vmax = [], 0.0
        for _ in range(int(round(duration / DT))):
            wc = st.control(x)
            if m is None:
                x = kern.rk4(x, wc, DT, pk)
            else:
                s = m.step(s, {"cmd_motor_speeds": wc}, DT)
                x = from_rotorpy(s)
            pos.append([x[1], x[0], -x[2]])
            vmax = max(vmax, float(np.linalg.norm(x[3:6])))
        pm = np.array(pos)
        prog = pm @ goal / length
        err = np.linalg.norm(pm - goal, axis=1)
        late = np.flatnonzero(err > 0.02 * length)
        out[side] = {
            "overshoot": 100.0 * (prog.max() - length) / length,
            "settle": (late[-1] + 2) * DT if len(late) else 0.0,
            "vmax": vmax,
        }
        paths.append(pm)
    out["rotorpy"]["apart"] = float(np.linalg.norm(paths[0] - paths[1], axis=1).max())
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-record", action="store_true", help="print only (no RESULTS.md entry)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    p = dataclasses.replace(QUADROTOR, rotor_tau_down=QUADROTOR.rotor_tau_up)
    rows: list[tuple[str, str, str]] = []
    ours_h, rp_h = p.hover_rotor_speed(0.0), rotorpy_hover(p)
    rows.append(
        (
            "hover rotor speed (rad/s), ours / rotorpy",
            f"{ours_h:.3f} / {rp_h:.3f} ({abs(ours_h / rp_h - 1):.1e})",
            "equal",
        )
    )
    att, pos = open_loop(p)
    rows.append(
        (
            "open loop 1 s: attitude / position difference",
            f"{att:.4f} deg / {pos * 1e3:.3f} mm",
            "small",
        )
    )
    for speed in (5.0, 12.0):
        r = closed_loop(p, (0.0, 20.0, 0.0), speed, 15.0)
        for side in ("ours", "rotorpy"):
            rows.append(
                (
                    f"20 m step at {speed:g} m/s, {side}: overshoot / to 2 %",
                    f"{r[side]['overshoot']:+.2f} % / {r[side]['settle']:.2f} s",
                    "<= 10 %",
                )
            )
        rows.append(
            (
                f"20 m step at {speed:g} m/s: the two flights apart",
                f"{r['rotorpy']['apart'] * 1e3:.2f} mm",
                "small",
            )
        )
    r = closed_loop(p, (0.0, 200.0, 0.0), 12.0, 25.0)
    rows.append(
        (
            "200 m at 12 m/s: top speed flown, ours / rotorpy",
            f"{r['ours']['vmax']:.2f} / {r['rotorpy']['vmax']:.2f} m/s",
            "12 m/s limit",
        )
    )
    rows.append(
        (
            "top speed at the 45 deg tilt limit, ours / rotorpy's forces",
            f"{top_speed(p):.2f} / {rotorpy_top_speed(p):.2f} m/s",
            "equal",
        )
    )
    notes = (
        "quadrotor preset (tau 12.5 ms both ways) in rotorpy's Multirotor and ours, 0 m AMSL; "
        f"{time.perf_counter() - t0:.0f} s"
    )
    emit("multirotor against rotorpy", rows, notes, args.no_record)


if __name__ == "__main__":
    main()
