"""The multi-view section of the report of a ``fringe3d merge`` folder: the fused model, the
per-view residuals and the coverage.

Reads ``merge.json`` (per view ``residual_rms_mm``, ``rotation_sigma_mrad``,
``translation_sigma_um``, ``points``, ``overlap_share``; ``fused_points``,
``fused_overlap_share``, ``mesh``), ``fused.ply`` (points mm, ``scalar_views``,
``scalar_sigma_mm``) and ``mesh.ply``; the truth figures come from ``evaluate.json``
(``multiview``: pose errors, fused RMS and coverage against the true surface; ``ball_bar``: the
VDI/VDE 2634-3 sphere-spacing error) or a ``truth`` entry of ``merge.json``.

The 3D view carries at most :data:`MAX_FUSED_POINTS` fused points (a fixed random subset) and a
mesh of at most :data:`MAX_MESH_TRIANGLES` triangles (vertex clustering on a cubic grid when the
mesh has more), as base64 uint16 coordinates (:func:`~.typed.b64_uint16`), so the page stays a
few MB whatever the merge's size.
"""
from __future__ import annotations

import base64
import html
import json
from pathlib import Path

import numpy as np

from fringe3d.utils.jsonfile import read_json

from .typed import b64_uint16

MAX_FUSED_POINTS = 40_000
MAX_MESH_TRIANGLES = 40_000
#: Per-view fields of merge.json: (key, column header with its unit, scale to the shown unit).
VIEW_COLUMNS = (("residual_rms_mm", "residual RMS (mm)", 1.0),
                ("rotation_sigma_mrad", "pose 1σ rotation (mrad)", 1.0),
                ("translation_sigma_um", "pose 1σ translation (µm)", 1.0),
                ("points", "points", 1),
                ("overlap_share", "overlap (%)", 100.0))
#: Per-view truth fields of evaluate.json's ``multiview`` section (key, header).
TRUTH_COLUMNS = (("rotation_error_mrad", "rotation error vs truth (mrad)"),
                 ("translation_error_um", "translation error vs truth (µm)"))

JS_U32 = ("function u32(b){const s=atob(b),n=s.length,u=new Uint8Array(n);"
          "for(let i=0;i<n;i++)u[i]=s.charCodeAt(i);return Array.from(new Uint32Array(u.buffer));}")


def _sample(n: int, limit: int, seed: int = 0) -> np.ndarray:
    if n <= limit:
        return np.arange(n)
    return np.sort(np.random.default_rng(seed).choice(n, limit, replace=False))


def cluster_mesh(vertices, faces, limit: int) -> tuple[np.ndarray, np.ndarray]:
    """At most ``limit`` triangles of a mesh, by vertex clustering: vertices merged into the mean of
    their cell of a cubic grid (the cell grown by √2 until the rest fits), faces that collapse
    dropped, duplicates kept once. A mesh already within ``limit`` is returned as it is."""
    V, F = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
    if len(F) <= limit or not len(V):
        return V, F
    span = float(np.ptp(V, axis=0).max()) or 1.0
    cell = span * np.sqrt(2.0 / len(F))  # about one vertex per cell of a mesh of that many triangles
    while True:
        key = np.floor((V - V.min(0)) / cell).astype(np.int64)
        _, vid = np.unique(key, axis=0, return_inverse=True)
        vid = vid.ravel()
        G = vid[F]
        G = G[(G[:, 0] != G[:, 1]) & (G[:, 1] != G[:, 2]) & (G[:, 0] != G[:, 2])]
        G = np.unique(G, axis=0)
        if len(G) <= limit:
            break
        cell *= np.sqrt(2.0)
    counts = np.bincount(vid)
    W = np.stack([np.bincount(vid, V[:, k]) for k in range(3)], axis=1) / counts[:, None]
    used, G = np.unique(G, return_inverse=True)
    return W[used], G.reshape(-1, 3)


def read_merge(folder: Path) -> dict | None:
    """What a merge folder holds for a report: ``{"summary": merge.json, "fused": {...} | None,
    "mesh": {...} | None}``, or None without ``merge.json``. ValueError naming the file and field
    when ``merge.json`` has no list of ``views``."""
    path = Path(folder) / "merge.json"
    if not path.is_file():
        return None
    summary = read_json(path, "merge summary")
    views = summary.get("views") if isinstance(summary, dict) else None
    if not isinstance(views, list) or not all(isinstance(v, dict) for v in views):
        raise ValueError(f"{path}: field 'views' must be a list of objects (one per view), as fringe3d merge "
                         "writes it")
    out: dict = {"summary": summary, "fused": None, "mesh": None}
    if (path.parent / "fused.ply").is_file():
        from fringe3d.io.pointcloud import read_ply

        pc = read_ply(path.parent / "fused.ply")
        ok = np.isfinite(pc.points).all(axis=1)
        idx = np.flatnonzero(ok)[_sample(int(ok.sum()), MAX_FUSED_POINTS)]
        out["fused"] = {"points": pc.points[idx], "total": int(ok.sum()),
                        **{k: pc.scalars[s][idx] for k, s in (("views", "views"), ("sigma", "sigma_mm"))
                           if s in pc.scalars}}
    if (path.parent / "mesh.ply").is_file():
        import trimesh

        mesh = trimesh.load(path.parent / "mesh.ply", file_type="ply", process=False)
        F = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), np.int64)
        if len(F):
            V, G = cluster_mesh(mesh.vertices, F, MAX_MESH_TRIANGLES)
            out["mesh"] = {"vertices": V, "faces": G, "total": len(F)}
    return out


def _b64_u32(values) -> str:
    return base64.b64encode(np.ascontiguousarray(values, dtype="<u4").tobytes()).decode("ascii")


def _coords(points) -> dict:
    d: dict = {}
    for i, ax in enumerate("xyz"):
        d[ax], d[ax + "0"], d["d" + ax] = b64_uint16(np.asarray(points)[:, i])
    return d


def model_script(m: dict, div: str) -> str:
    """JavaScript drawing the fused sample (coloured by the number of views, a button switches to
    σ) and the mesh (a button shows it) of :func:`read_merge`'s ``m`` in ``div``."""
    fused, mesh = m["fused"], m["mesh"]
    data: dict = {}
    pts = []
    if fused is not None:
        data["p"] = _coords(fused["points"])
        pts.append(np.asarray(fused["points"]))
        for k in ("views", "sigma"):
            if k in fused:
                data[k] = b64_uint16(fused[k])
    if mesh is not None:
        data["m"] = {**_coords(mesh["vertices"]), "f": _b64_u32(np.asarray(mesh["faces"]).ravel())}
        pts.append(np.asarray(mesh["vertices"]))
    allp = np.concatenate(pts) if pts else np.zeros((0, 3))
    span = np.ptp(allp, axis=0) if len(allp) else np.ones(3)
    ratio = np.maximum(span / max(float(span.max()), 1e-12), 0.25)
    layout = {"margin": {"l": 0, "r": 0, "t": 40, "b": 0}, "showlegend": False,
              "scene": {"aspectmode": "manual", "aspectratio": dict(zip("xyz", map(float, ratio))),
                        "xaxis": {"title": {"text": "x (mm)"}}, "yaxis": {"title": {"text": "y (mm)"}},
                        "zaxis": {"title": {"text": "z (mm)"}},
                        # the model frame is view 0's camera frame: seen from that camera's side
                        "camera": {"up": {"x": 0, "y": -1, "z": 0}, "eye": {"x": 0.5, "y": -0.5, "z": -1.7}}}}
    has_views = fused is not None and "views" in fused and len(fused["views"]) > 0
    max_views = int(np.nanmax(fused["views"])) if has_views else 1
    return (JS_U32 + f"(function(){{const d={json.dumps(data)},L={json.dumps(layout)},tr=[],b=[];"
            "const xyz=c=>[u16(c.x,c.x0,c.dx),u16(c.y,c.y0,c.dy),u16(c.z,c.z0,c.dz)];"
            "if(d.p){const [x,y,z]=xyz(d.p);"
            "const v=d.views?u16(...d.views):null,s=d.sigma?u16(...d.sigma):null;"
            "tr.push({type:'scatter3d',mode:'markers',name:'fused points',x:x,y:y,z:z,"
            f"marker:{{size:{_marker_size(len(fused['points'])) if fused is not None else 2},color:v||z,"
            "colorscale:'Viridis',cmin:v?1:undefined,"
            f"cmax:v?Math.max(2,{max_views}):undefined,"
            "colorbar:{title:{text:v?'views':'z (mm)'},dtick:v?1:undefined}}});"
            "if(v)b.push({label:'points: views',method:'update',args:[{visible:[true,false],'marker.color':[v],"
            "'marker.cmin':1,'marker.cmax':Math.max(2," + str(max_views) + "),'marker.colorbar.title.text':'views',"
            "'marker.colorbar.dtick':1}]});"
            "if(s){let lo=Infinity,hi=-Infinity;for(const q of s){if(q<lo)lo=q;if(q>hi)hi=q;}"
            "b.push({label:'points: σ (mm)',method:'update',args:[{visible:[true,false],'marker.color':[s],"
            "'marker.cmin':lo,'marker.cmax':hi>lo?hi:lo+1e-6,'marker.colorbar.title.text':'σ (mm)',"
            "'marker.colorbar.dtick':null}]});}}"
            "if(d.m){const [x,y,z]=xyz(d.m),f=u32(d.m.f),i=[],j=[],k=[];"
            "for(let t=0;t<f.length;t+=3){i.push(f[t]);j.push(f[t+1]);k.push(f[t+2]);}"
            "tr.push({type:'mesh3d',name:'mesh',x:x,y:y,z:z,i:i,j:j,k:k,color:'#9fb4c8',flatshading:false,"
            "lighting:{ambient:0.45,diffuse:0.8,specular:0.15},visible:!d.p});"
            "if(d.p)b.push({label:'mesh',method:'update',args:[{visible:[false,true]}]});}"
            "if(b.length>1)L.updatemenus=[{type:'buttons',direction:'right',x:0,xanchor:'left',y:1.0,"
            "yanchor:'bottom',pad:{t:2,b:2},showactive:true,buttons:b}];"
            f"Plotly.newPlot({json.dumps(div)},tr,L,{{responsive:true,displaylogo:false}});}})();")


def _marker_size(n: int) -> float:
    """Marker size (px) of ``n`` points: larger for a sparse cloud, so it reads as a surface."""
    return 3.0 if n < 10_000 else 2.0 if n < 30_000 else 1.5


def _share(x) -> float | None:
    return None if x is None else 100.0 * float(x)


def view_rows(summary: dict, truth: dict | None) -> tuple[list[str], list[list]]:
    """Header and one row per view of merge.json (values in the header's units; None shown as —),
    with the truth's pose errors when ``truth`` (evaluate.json's ``multiview``) names the view."""
    by_name = {t.get("name"): t for t in (truth or {}).get("views", []) if isinstance(t, dict)}
    truth_cols = [c for c in TRUTH_COLUMNS if any(c[0] in t for t in by_name.values())]
    header = ["view"] + [h for _, h, _ in VIEW_COLUMNS] + [h for _, h in truth_cols]
    rows = []
    for v in summary["views"]:
        row = [v.get("name", "?")]
        for key, _, scale in VIEW_COLUMNS:
            x = v.get(key)
            row.append(None if x is None else (x * scale if scale != 1 else x))
        t = by_name.get(v.get("name"), {})
        row += [t.get(k) for k, _ in truth_cols]
        rows.append(row)
    return header, [[float("nan") if x is None else x for x in r] for r in rows]


def figure_rows(summary: dict, fused_total: int | None, evaluation: dict | None) -> list[list]:
    """``[figure, value, unit, definition]`` rows of the merge: views, fused points, the share seen
    by ≥ 2 views, σ, stage prior, mesh, and the truth figures when there are any."""
    rows: list[list] = [["views", len(summary["views"]), "", "views registered and fused"]]
    n = summary.get("fused_points", fused_total)
    if n is not None:
        rows.append(["fused points", n, "", "one per occupied fusion voxel (fused.ply)"])
    if summary.get("fused_overlap_share") is not None:
        rows.append(["seen by ≥ 2 views", _share(summary["fused_overlap_share"]), "%",
                     "share of the fused points whose voxel two or more views met"])
    if summary.get("fused_sigma_median_mm") is not None:
        rows.append(["fused σ median", summary["fused_sigma_median_mm"], "mm",
                     "median 1σ of the fused points, (Σ 1/σᵢ²)^(-1/2) per voxel"])
    prior = summary.get("stage_prior")
    if isinstance(prior, dict):
        rows.append(["stage prior", f"{prior.get('rotation_mrad')} mrad, {prior.get('translation_mm')} mm", "",
                     "the stage's stated 1σ per axis that held each pose near its stage pose"])
    mesh = summary.get("mesh")
    if isinstance(mesh, dict):
        rows += [["mesh triangles", mesh.get("triangles"), "", "screened Poisson, density-trimmed (mesh.ply)"],
                 ["mesh watertight", mesh.get("watertight"), "", "every edge shared by exactly two triangles"],
                 ["mesh area", mesh.get("area_mm2"), "mm²", "surface area of the mesh"]]
    ev = evaluation or {}
    truth = summary.get("truth") if isinstance(summary.get("truth"), dict) else ev.get("multiview")
    if isinstance(truth, dict):
        for key, label, unit, scale, definition in (
                ("fused_rms_mm", "fused RMS vs truth", "mm", 1.0, "sqrt(mean(e²)), e = point-to-plane distance "
                 "of a fused point to the true surface"),
                ("coverage", "coverage of the true surface", "%", 100.0, "share of the true visible surface with "
                 "a fused point within the coverage radius"),
                ("coverage_radius_mm", "coverage radius", "mm", 1.0, "distance within which a true point counts "
                 "as seen"),
                ("rotation_error_max_mrad", "largest pose rotation error", "mrad", 1.0, "angle of T_true⁻¹ T_est, "
                 "both tied to view 0"),
                ("translation_error_max_um", "largest pose translation error", "µm", 1.0, "how far that error "
                 "moves the object's centre")):
            if truth.get(key) is not None:
                rows.append([label, truth[key] * scale, unit, definition])
    bb = ev.get("ball_bar")
    if isinstance(bb, dict) and bb.get("error") is not None:
        rows.append(["sphere-spacing error SD", bb["error"], "mm", "measured - calibrated distance of the two "
                     "sphere centres in the fused cloud (VDI/VDE 2634-3)"])
    return rows


def multiview_parts(m: dict, evaluation: dict | None, table) -> tuple[list[str], list[str]]:
    """``(html parts, scripts)`` of the multi-view section of :func:`read_merge`'s ``m``
    (``table(rows, header, cls)`` renders a table)."""
    s = m["summary"]
    ev = evaluation or {}
    truth = s.get("truth") if isinstance(s.get("truth"), dict) else ev.get("multiview")
    parts = ["<h2>Multi-view merge</h2>",
             "<p class='muted'>model frame: view 0's camera frame, mm · merge.json, fused.ply, mesh.ply</p>"]
    scripts = []
    fused, mesh = m.get("fused"), m.get("mesh")
    if fused is not None or mesh is not None:
        what = []
        if fused is not None:
            shown = len(fused["points"])
            what.append(f"fused points: {fused['total']}" + (f", {shown} shown" if shown < fused["total"] else "")
                        + ", coloured by the number of views that met each point (a button switches to σ)")
        if mesh is not None:
            n = len(mesh["faces"])
            what.append(f"mesh: {mesh['total']} triangles" + (f", {n} shown (vertex clustering)"
                                                             if n < mesh["total"] else ""))
        parts.append(f"<h3>Fused model</h3><p class='muted'>{html.escape('; '.join(what))}</p>"
                     '<div id="plot3d_merge" class="plot3d"></div>')
        scripts.append(model_script(m, "plot3d_merge"))
    header, rows = view_rows(s, truth)
    parts.append("<h3>Per view</h3><p class='muted'>residual RMS: point-to-plane distance to the other views; pose 1σ "
                 "from the pose graph (largest over directions; translation of the view's object centre), — where "
                 "nothing constrains a direction, 0 for view 0 (it fixes the model frame); overlap: share of the "
                 "view's fusion voxels another view met too</p><div class='scroll'>"
                 + table(rows, header, "views") + "</div>")
    parts.append("<h3>Coverage and figures</h3><div class='scroll'>"
                 + table(figure_rows(s, fused["total"] if fused else None, ev), ["figure", "value", "unit",
                                                                               "definition"], "figures merge")
                 + "</div>")
    return parts, scripts
