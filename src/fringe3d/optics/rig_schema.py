"""The rig file's schema (``rig.json``, and the ``rig`` entry of a calibration file).

Beyond types and finiteness (pydantic), a rig must be physically usable before any pixel is
triangulated: intrinsics ``K`` upper-triangular with positive focal lengths and ``K[2] = (0, 0, 1)``
(Eq. 2.9), rotations orthonormal with determinant +1 (Eq. 2.10; a sheared ``R`` would scale depth),
distortion with 0, 4, 5, 8, 12 or 14 coefficients (OpenCV's orders), a telecentric ``M`` of rank 2
(Eq. 3.1-3.3), and distinct camera and projector centres (a positive baseline, Eq. 2.35-2.38).
"""
from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from fringe3d.optics.distortion import OPENCV_LENGTHS
from fringe3d.utils.schema import UNION_TAGS, FiniteFloat, Size, Strict, StrictInt, validate

Row3 = Annotated[list[FiniteFloat], Field(min_length=3, max_length=3)]
Row4 = Annotated[list[FiniteFloat], Field(min_length=4, max_length=4)]
Matrix3 = Annotated[list[Row3], Field(min_length=3, max_length=3)]
#: OpenCV distortion vector lengths (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [tx ty]]]]), or none.
DIST_LENGTHS = (0,) + OPENCV_LENGTHS
ORTHONORMAL_TOL = 1e-6
UNION_TAGS.update({"pinhole", "telecentric"})


class PinholeModel(Strict):
    kind: Literal["pinhole"] = "pinhole"
    K: Matrix3
    dist: Annotated[list[FiniteFloat], Field(max_length=14)] = []
    width: Size
    height: Size
    R: Matrix3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    t: Row3 = [0.0, 0.0, 0.0]

    @model_validator(mode="after")
    def _usable(self) -> "PinholeModel":
        K = np.asarray(self.K, float)
        if not (K[0, 0] > 0 and K[1, 1] > 0):
            raise ValueError(f"K: focal lengths fx = K[0][0] and fy = K[1][1] must be positive, got {K[0, 0]}, "
                             f"{K[1, 1]}")
        if K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or K[2, 2] != 1:
            raise ValueError("K: expected an intrinsic matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]]")
        if len(self.dist) not in DIST_LENGTHS:
            raise ValueError(f"dist: expected {', '.join(map(str, DIST_LENGTHS))} coefficients (OpenCV's order k1 k2 "
                             f"p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [tau_x tau_y]]]]), got {len(self.dist)}")
        R = np.asarray(self.R, float)
        with np.errstate(over="ignore", invalid="ignore"):  # huge entries: err is inf, and refused
            err = float(np.abs(R.T @ R - np.eye(3)).max())
        if err > ORTHONORMAL_TOL or np.linalg.det(R) < 0:
            raise ValueError(f"R: expected a rotation (orthonormal, determinant +1); |R^T R - I| = {err:.3g}, "
                             f"det = {np.linalg.det(R):.6g}")
        return self


class TelecentricModel(Strict):
    kind: Literal["telecentric"]
    M: Annotated[list[Row4], Field(min_length=2, max_length=3)]
    width: Size
    height: Size

    @model_validator(mode="after")
    def _usable(self) -> "TelecentricModel":
        M = np.asarray(self.M, float)
        if np.linalg.matrix_rank(M[:2, :3]) < 2:
            raise ValueError("M: the 2x3 projection part must have rank 2 (a telecentric lens images a plane)")
        return self


Device = Annotated[PinholeModel | TelecentricModel, Field(discriminator="kind")]


class ResponseModel(Strict):
    """The projector's measured response (issue 25): ``response[i] = r(inputs[i])``, both in [0, 1]."""

    inputs: Annotated[list[FiniteFloat], Field(min_length=2)]
    response: Annotated[list[FiniteFloat], Field(min_length=2)]

    @model_validator(mode="after")
    def _monotone(self) -> "ResponseModel":
        x, r = np.asarray(self.inputs), np.asarray(self.response)
        if x.shape != r.shape:
            raise ValueError(f"inputs and response must have the same length, got {x.size} and {r.size}")
        if x[0] != 0 or x[-1] != 1 or np.any(np.diff(x) <= 0):
            raise ValueError("inputs: expected increasing projector inputs from 0 to 1")
        if r[0] != 0 or r[-1] != 1 or np.any(np.diff(r) < 0):
            raise ValueError("response: expected a non-decreasing normalised response from 0 to 1")
        return self


class RigModel(Strict):
    format: Literal["fringe3d-rig"] = "fringe3d-rig"
    version: Annotated[StrictInt, Field(ge=1, le=2)] = 1
    camera: Device
    projector: PinholeModel
    projector_response: ResponseModel | None = None

    @model_validator(mode="after")
    def _baseline(self) -> "RigModel":
        if isinstance(self.camera, PinholeModel):
            def centre(d: PinholeModel) -> np.ndarray:
                return -np.asarray(d.R, float).T @ np.asarray(d.t, float)
            if np.linalg.norm(centre(self.camera) - centre(self.projector)) < 1e-9:
                raise ValueError("camera and projector centres coincide: a rig needs a baseline to triangulate")
        return self


def _with_kind(d):
    if isinstance(d, dict) and "kind" not in d:
        return {**d, "kind": "pinhole"}
    return d


def validate_rig(d: dict, where: str = "rig file") -> None:
    """Raise ``ValueError`` naming the field when ``d`` is not a usable rig (see the module docstring)."""
    if not isinstance(d, dict):
        raise ValueError(f"{where}: expected a JSON object, got {type(d).__name__}")
    validate(RigModel, {k: _with_kind(v) if k in ("camera", "projector") else v for k, v in d.items()}, where)
