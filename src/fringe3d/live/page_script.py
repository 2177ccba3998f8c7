"""The live page's own measurement: display latency and drawn frame rate, timed in the browser.

The pipeline (:mod:`fringe3d.live.stats`) times a 3D frame up to the moment its points are
handed to the page. What a user sees is later: the message crosses the websocket, the page
decodes it, builds the cloud's buffers and draws the next animation frame. :data:`SCRIPT` is
JavaScript that :class:`fringe3d.live.viewer.ViserViewer` runs in the page (viser's
``RunJavascriptMessage``, the mechanism viser uses to load plotly.js). With each cloud the
viewer sends, in the same atomic update, a stamp element (:func:`frame_stamp`): the frame's
number and the host time its cycle's last camera frame arrived (epoch ms). The script watches
the page for a new stamp (a ``MutationObserver``: the update was applied), waits for the next
animation frame (the one that draws the cloud) and the task after it, and takes the time
(``Date.now()``, epoch ms: page and host read the same wall clock; ``performance.timeOrigin +
performance.now()`` follows a monotonic clock that drifts from it, by tens of ms within a minute
on the development machine). Display latency = that time - the arrival stamp.

In the depth view (the stamp's :data:`VIEW_ATTRIBUTE` reads ``depth``) the frame is an image:
viser sets the GUI image's ``src`` (a new blob URL) a React effect after the update that carries
the stamp. The script waits for the image element labelled :data:`DEPTH_LABEL` to take a new
``src`` (the ``MutationObserver`` watches ``src`` attributes too), for the image to load and
decode (``img.decode()``, or its ``load`` event: a decode promise has stayed pending in headless
Chromium), then for the next animation frame and the task after it, and takes the time as above
(a frame whose image is replaced before it is drawn is not counted). While the depth view is on,
the script lays the image over the 3D view (fixed, centred on the canvas's box, at the image's
own size: a scaled image costs a software rasteriser more per frame) and hides the 3D canvas
(``display: none``: the browser neither draws nor composites it); the cloud view undoes both.

The page shows, under the view, the frames it drew, their rate (``(drawn - 1) / (last -
first)``, on ``performance.now()``) and the display latency median, p95 and max (percentiles
interpolated linearly between order statistics, as NumPy's default), and keeps the raw lists in
``window.fringe3dDisplay`` (``frame``, ``arrival``, ``received``, ``drawn`` (epoch ms), ``tick``
(``performance.now()`` when drawn), ``latency``, all per drawn frame, and ``summary``) for a
benchmark or a test to read. Frames the page never drew (two updates applied in one animation
frame: only the newer is drawn) are not counted.

When it starts (frame 0) and after drawing a frame the script writes its number into the GUI
field labelled
:data:`ACK_LABEL` (as if typed: viser has no other way for page code to talk to the server; the
script hides that field), so the viewer knows what the page has drawn
(:meth:`fringe3d.live.viewer.ViserViewer.busy`) and the loop does not send clouds faster than the
page draws them.
"""
from __future__ import annotations

#: The stamp element's attributes: the frame's number and its arrival time (epoch ms).
FRAME_ATTRIBUTE = "data-fringe3d-frame"
ARRIVAL_ATTRIBUTE = "data-fringe3d-arrival"
#: The label of the GUI field the page writes the last frame it drew into.
ACK_LABEL = "page drew frame"
#: The id of the page element that shows the page's figures.
FIGURES_ID = "fringe3d-display"
#: The stamp's attribute naming the view of its frame (``cloud`` when absent, or ``depth``).
VIEW_ATTRIBUTE = "data-fringe3d-view"
#: The label of the GUI image element that shows the depth view.
DEPTH_LABEL = "depth map"

SCRIPT = r"""
(() => {
  if (window.fringe3dDisplay) return;  // the script is replayed on a reconnect
  const now = () => Date.now();  // the wall clock, as the host's stamps (a monotonic clock drifts from it)
  const d = window.fringe3dDisplay = {frame: [], arrival: [], received: [], drawn: [], tick: [], latency: [],
                                      summary: null};
  const box = document.createElement('div');
  box.id = '%(figures)s';
  box.style.cssText = 'position:fixed;left:8px;bottom:8px;z-index:1000;font:12px monospace;color:#222;' +
    'background:rgba(255,255,255,0.85);padding:3px 6px;border-radius:4px;pointer-events:none;white-space:pre';
  box.textContent = 'in this page: waiting for 3D frames';
  document.body.appendChild(box);
  const quantile = (sorted, q) => {
    const h = (sorted.length - 1) * q, i = Math.floor(h), j = Math.min(i + 1, sorted.length - 1);
    return sorted[i] + (h - i) * (sorted[j] - sorted[i]);
  };
  const round = x => Math.round(x * 10) / 10;
  const update = () => {
    const n = d.drawn.length, s = [...d.latency].sort((a, b) => a - b);
    const fps = n > 1 && d.tick[n - 1] > d.tick[0] ? (n - 1) / ((d.tick[n - 1] - d.tick[0]) / 1000) : 0;
    d.summary = {frames_drawn: n, last_frame: d.frame[n - 1], fps: round(fps),
                 latency_ms: {median: round(quantile(s, 0.5)), p95: round(quantile(s, 0.95)), max: round(s[n - 1])}};
    const l = d.summary.latency_ms;
    box.textContent = `in this page: ${n} 3D frames drawn, ${d.summary.fps.toFixed(1)} frames/s; ` +
      `display latency (arrival to drawn) median ${l.median.toFixed(1)} ms, p95 ${l.p95.toFixed(1)} ms, ` +
      `max ${l.max.toFixed(1)} ms`;
  };
  let last = null, pending = null, scheduled = false, timer = null;
  const setter = Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, 'value').set;
  let ackInput = null;
  const acknowledge = frame => {  // tell the server (a GUI text field, as if typed): it paces the clouds
    if (!ackInput || !ackInput.isConnected) {  // found once (a search of the page is slow), again if re-made
      const label = [...document.querySelectorAll('label, p, span, div')].filter(
        e => e.textContent.trim() === '%(ack)s').pop();
      let row = label;
      while (row && !row.querySelector('input')) row = row.parentElement;
      ackInput = row && row.querySelector('input');
      if (!ackInput) return false;
      row.style.display = 'none';  // the page's own field, not a control
    }
    setter.call(ackInput, String(frame));
    ackInput.dispatchEvent(new Event('input', {bubbles: true}));
    return true;
  };
  const hello = () => { if (!acknowledge(0)) setTimeout(hello, 100); };  // "drew frame 0": paced from the first
  const drawn = (p, t) => {
    acknowledge(p.frame);
    d.frame.push(p.frame); d.arrival.push(p.arrival); d.received.push(p.received); d.drawn.push(t);
    d.tick.push(performance.now());
    d.latency.push(t - p.arrival);
    if (timer === null) timer = setTimeout(() => { timer = null; update(); }, 250);  // a few times a second
  };
  let depthImg = null;
  const depthImage = () => {  // the img of the GUI image element labelled '%(depth)s' (found once, as above)
    if (depthImg && depthImg.isConnected) return depthImg;
    const label = [...document.querySelectorAll('p, span, div')].filter(
      e => e.childElementCount === 0 && e.textContent.trim() === '%(depth)s').pop();
    depthImg = label ? label.parentElement.querySelector('img') : null;
    return depthImg;
  };
  let view = 'cloud', depthPending = null, depthSeen = null;
  const layOut = img => {  // the depth image over the 3D view, the canvas hidden (or back)
    const canvas = document.querySelector('canvas');
    if (view === 'depth' && img && canvas) {
      const r = canvas.parentElement.getBoundingClientRect();  // the canvas's box (kept while it is hidden)
      // at its own size (a scaled image costs the software rasteriser more per frame), centred
      const w = img.naturalWidth || 0, h = img.naturalHeight || 0;
      Object.assign(img.style, {position: 'fixed', left: Math.max(r.left, r.left + (r.width - w) / 2) + 'px',
                                top: Math.max(r.top, r.top + (r.height - h) / 2) + 'px', maxWidth: 'none',
                                zIndex: 900});
    }
    if (canvas) canvas.style.display = view === 'depth' ? 'none' : '';
  };
  let depthShown = null, token = 0;
  const ready = img => new Promise(go => {  // loaded and decoded; decode() alone has stayed pending in headless
    img.decode().then(go, go);              // Chromium, so its load event (or, already loaded, 50 ms) ends the wait
    img.addEventListener('load', () => go(), {once: true});
    if (img.complete && img.naturalWidth > 0) setTimeout(go, 50);
  });
  const lookDepth = () => {
    if (!depthPending) return;
    const img = depthImage(), src = img && img.getAttribute('src');
    if (!src || (img === depthShown && src === depthSeen)) return;  // its image has not arrived yet
    depthShown = img;
    depthSeen = src;
    const p = depthPending, mine = ++token;  // a newer image before this one is drawn: this one is not counted
    depthPending = null;
    // placed once loaded (its size known); the next animation frame draws it; the task after it runs once drawn
    ready(img).then(() => {
      if (mine === token) layOut(img);
      requestAnimationFrame(() => setTimeout(() => {
        if (mine === token && img.getAttribute('src') === src) drawn(p, now());
      }, 0));
    });
  };
  const look = () => {
    lookDepth();
    const el = document.querySelector('[%(frame)s]');
    if (!el) return;
    const frame = Number(el.getAttribute('%(frame)s'));
    if (frame === last || frame < 1) return;  // frame 0: the stamp before the first cloud
    last = frame;
    const stamp = {frame, arrival: Number(el.getAttribute('%(arrival)s')), received: now()};
    const shown = el.getAttribute('%(view)s') || 'cloud';
    if (shown !== view) { view = shown; layOut(depthImage()); }
    if (view === 'depth') {
      depthPending = stamp;  // drawn once its image is decoded (a newer stamp replaces it)
      lookDepth();
      return;
    }
    pending = stamp;
    if (scheduled) return;  // a newer update before the next animation frame: only it is drawn
    scheduled = true;
    // the next animation frame draws the cloud; the task after it runs once it is drawn
    requestAnimationFrame(() => {
      const p = pending;
      pending = null;
      scheduled = false;
      setTimeout(() => drawn(p, now()), 0);
    });
  };
  new MutationObserver(look).observe(document.body, {subtree: true, childList: true, attributes: true,
                                                     attributeFilter: ['src']});
  hello();
  look();
})();
""" % {"ack": ACK_LABEL, "figures": FIGURES_ID, "frame": FRAME_ATTRIBUTE, "arrival": ARRIVAL_ATTRIBUTE,
       "view": VIEW_ATTRIBUTE, "depth": DEPTH_LABEL}


def frame_stamp(frame: int, arrival_ms: float, view: str = "cloud") -> str:
    """The stamp element sent with a frame's cloud or depth image.

    Parameters
    ----------
    frame : int
        The frame's number (1 for the first shown).
    arrival_ms : float
        Host time its cycle's last camera frame arrived (ms since the epoch).
    view : str
        ``"cloud"`` or ``"depth"``: what the frame is drawn as.

    Returns
    -------
    str
        An empty ``<span>`` carrying the three as attributes.
    """
    return (f'<span {FRAME_ATTRIBUTE}="{int(frame)}" {ARRIVAL_ATTRIBUTE}="{arrival_ms:.3f}" '
            f'{VIEW_ATTRIBUTE}="{view}"></span>')
