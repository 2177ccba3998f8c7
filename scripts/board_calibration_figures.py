"""Reprojection RMS and errors against the true rig: circle grid + phase vs chessboard / ChArUco + Gray code.

Usage: PYTHONPATH=src .venv/bin/python scripts/board_calibration_figures.py [--preset macro] [--poses 12]
       [--seed 0] [--camera-scale 0.5] [--json]

Each row renders a simulated calibration session of the same rig (the preset's sensor noise:
shot + read noise, 8-bit frames; the same seeded board poses for boards of one size), calibrates
it (``camera_dist="k1k2"``, linear projector) and prints the camera and projector reprojection
RMS (px) beside the errors against the simulator's true rig:

* circles + phase: the dissertation's route (three-frequency phase, Eq. 2.30-2.31), the
  preset's projector defocus;
* chessboard / ChArUco + Gray code: OpenCV's 1-px Gray-code layout with a sharp projector
  (defocus 0.3 px; Moreno & Taubin's local homographies need decodable 1-px stripes);
* chessboard + Gray code with the preset's defocus: the code's finest stripe widened to stay
  decodable (2 px for 1 px defocus);
* chessboard + phase: the board's corners through the phase set.

The ChArUco session has two partial views (the last two poses).
"""
from __future__ import annotations

import argparse
import json
import time

from fringe3d.calibrate.evaluation import compare_to_truth
from fringe3d.calibrate.session import calibrate_observations, observe_session
from fringe3d.calibrate.square_boards import CharucoBoard, ChessBoard
from fringe3d.sim.calibration_session import PoseRanges, SessionOptics, simulate_session

ROWS = (
    ("circles + phase", {"board": None, "patterns": "phase"}),
    ("chessboard + Gray code (sharp)", {"board": "chess", "patterns": "gray-code", "defocus": 0.3}),
    ("ChArUco + Gray code (sharp, 2 partial)", {"board": "charuco", "patterns": "gray-code", "defocus": 0.3,
                                                "partial": 2}),
    ("chessboard + Gray code (preset defocus)", {"board": "chess", "patterns": "gray-code"}),
    ("chessboard + phase", {"board": "chess", "patterns": "phase"}),
)


def run(preset: str, poses: int, seed: int, scale: float) -> list[dict]:
    boards = {"chess": ChessBoard(cols=11, rows=9, spacing=13.0),
              "charuco": CharucoBoard(cols=8, rows=6, spacing=16.0, marker=11.2)}
    out = []
    for name, opt in ROWS:
        t0 = time.time()
        board = boards.get(opt["board"]) if opt["board"] else None
        ss = simulate_session(preset, n_poses=poses, seed=seed, patterns=opt["patterns"], board=board, progress=False,
                              optics=SessionOptics(camera_scale=scale, defocus=opt.get("defocus")),
                              pose_ranges=PoseRanges(partial=opt.get("partial", 0)))
        obs, info = observe_session(ss.poses, ss.board, progress=False)
        cal, _ = calibrate_observations(obs, info, ss.board, camera_dist="k1k2")
        err = compare_to_truth(cal.rig, ss.rig)
        out.append({"session": name, "poses_used": len(obs), "points": sum(p["points"] for p in cal.poses),
                    "camera_rms_px": cal.rms["camera_px"], "projector_rms_px": cal.rms["projector_px"],
                    "correspondences": info["correspondences"], **err, "seconds": time.time() - t0})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="macro")
    ap.add_argument("--poses", type=int, default=12)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--camera-scale", type=float, default=0.5)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    rows = run(a.preset, a.poses, a.seed, a.camera_scale)
    if a.json:
        print(json.dumps(rows, indent=1))
        return
    print(f"{a.preset}, camera scale {a.camera_scale}, {a.poses} poses, seed {a.seed}, preset noise")
    head = ("session", "poses", "cam RMS px", "prj RMS px", "cam f rel", "cam pp px", "prj f rel", "prj pp px",
            "t mm", "R deg")
    print(" | ".join(head))
    for r in rows:
        print(" | ".join([r["session"], str(r["poses_used"])] + [
            f"{r[k]:.4f}" if "rel" not in k else f"{r[k]:.2e}"
            for k in ("camera_rms_px", "projector_rms_px", "camera_focal_rel_error", "camera_principal_point_error_px",
                      "projector_focal_rel_error", "projector_principal_point_error_px", "translation_error_norm_mm",
                      "rotation_error_deg")]))


if __name__ == "__main__":
    main()
