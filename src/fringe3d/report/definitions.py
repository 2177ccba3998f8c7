"""What each figure of ``evaluate.json`` means, shown beside its value in a report (units: mm
unless named). VDI/VDE 2634 Part 2 defines P_F, P_S, SD and F for calibrated artefacts."""
from __future__ import annotations

#: section -> figure -> (label, unit, definition)
DEFINITIONS: dict[str, dict[str, tuple[str, str, str]]] = {
    "sphere": {
        "form": ("probing error form P_F", "mm", "max - min of the radial residuals |p - c| - r of the sphere fitted "
                 "with free radius (VDI/VDE 2634-2)"),
        "size": ("probing error size P_S", "mm", "fitted diameter - calibrated diameter (VDI/VDE 2634-2)"),
        "diameter": ("fitted diameter", "mm", "2 r of the geometric least-squares sphere"),
        "true_diameter": ("calibrated diameter", "mm", "from the stated diameter or the true surface"),
        "rms": ("sphere RMS", "mm", "sqrt(mean((|p - c| - r)^2)) over the points kept"),
        "fit_rms": ("fit RMS", "mm", "RMS of the radial residuals of the fit"),
        "n_points": ("points", "", "points in the fit after outlier exclusion"),
    },
    "plane": {
        "flatness": ("flatness error F", "mm", "max - min of the signed distances n.p - d to the fitted plane "
                     "(VDI/VDE 2634-2)"),
        "rms": ("plane RMS", "mm", "sqrt(mean((n.p - d)^2)) over the points kept"),
        "n_points": ("points", "", "points in the fit after outlier exclusion"),
    },
    "ball_bar": {
        "error": ("sphere-spacing error SD", "mm", "measured - calibrated distance between the two sphere centres "
                  "(VDI/VDE 2634-2)"),
        "distance": ("measured centre distance", "mm", "|c_a - c_b| of the two free-radius sphere fits"),
        "true_distance": ("calibrated distance", "mm", "from the stated distance or the true surface"),
    },
    "truth": {
        "rms_mm": ("3D error RMS", "mm", "sqrt(mean(e^2)), e = distance of a measured point to the true surface"),
        "mean_mm": ("3D error mean", "mm", "mean(e)"),
        "median_mm": ("3D error median", "mm", "median(e)"),
        "max_mm": ("3D error max", "mm", "max(e)"),
        "coverage": ("coverage", "", "share of the true surface's pixels with a measured point"),
        "share_over_1mm": ("share over 1 mm", "", "share of points with e > 1 mm"),
        "points": ("points", "", "points compared"),
    },
}

SECTION_TITLES = {"truth": "Error against the truth", "sphere": "Sphere (probing errors)",
                  "plane": "Plane (flatness)", "ball_bar": "Ball bar (sphere spacing)"}
