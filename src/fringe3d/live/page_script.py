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

In the depth view the stamp is the frame: an ``<img>`` carrying the same two attributes and the
depth image as a ``data:`` URL (JPEG; :func:`frame_stamp`), so a frame is one viser message (a
GUI update, which does not wake viser's 3D render loop). The script hides that element (a page
without the script shows it as a plain image), decodes its JPEG off the main thread (an
``Image`` of the same ``data:`` URL and its ``decode()``: no bytes copied by script, no ``Blob``,
which costs the main thread about 2 ms a frame) and draws it into the page's own canvas (id
:data:`DEPTH_CANVAS_ID`),
then waits for the next animation frame and the task after it and takes the time as above. A
frame whose image was drawn in the canvas and replaced before an animation frame showed it, or
that finished decoding after a newer one, is not counted. While the depth view is on, the canvas
lies over the 3D view (fixed, centred on the 3D canvas's box, at the image's own size: a scaled
image costs a software rasteriser more per frame) and the 3D canvas is hidden (``display:
none``: the browser neither draws nor composites it); a cloud's stamp undoes both.

The page shows, under the view, the frames it drew, their rate (``(drawn - 1) / (last -
first)``, on ``performance.now()``) and the display latency median, p95 and max (percentiles
interpolated linearly between order statistics, as NumPy's default), and keeps the raw lists in
``window.fringe3dDisplay`` (``frame``, ``arrival``, ``received``, ``drawn`` (epoch ms), ``tick``
(``performance.now()`` when drawn), ``latency``, all per drawn frame, ``summary``, and
``acknowledged``: how the page acknowledges frames, ``"worker"`` or ``"field"``) for a
benchmark or a test to read. Frames the page never drew (two updates applied in one animation
frame: only the newer is drawn) are not counted.

When it starts (frame 0) and after drawing a frame the script tells the server the frame's
number through the GUI field labelled :data:`ACK_LABEL` (viser has no API for page code to talk
to the server; the script hides that field), so the viewer knows what the page has drawn
(:meth:`fringe3d.live.viewer.ViserViewer.busy`) and the loop does not send frames faster than
the page draws them. The first time (frame 0) it types the number into the field; viser's page
hands the field's update (a ``GuiUpdateMessage``) to the web worker that holds its websocket,
and the script, watching ``Worker.prototype.postMessage``, keeps that worker and the field's id.
From then on it posts each number's update to that worker itself: the same message, without a
React update of the hidden field and without viser's 50 ms throttle of typed values (a page
where that is not seen keeps typing).
"""
from __future__ import annotations

import base64

#: The stamp element's attributes: the frame's number and its arrival time (epoch ms).
FRAME_ATTRIBUTE = "data-fringe3d-frame"
ARRIVAL_ATTRIBUTE = "data-fringe3d-arrival"
#: The label of the GUI field the page writes the last frame it drew into.
ACK_LABEL = "page drew frame"
#: The id of the page element that shows the page's figures.
FIGURES_ID = "fringe3d-display"
#: The id of the page's canvas that shows the depth view.
DEPTH_CANVAS_ID = "fringe3d-depth"

SCRIPT = r"""
(() => {
  if (window.fringe3dDisplay) return;  // the script is replayed on a reconnect
  const now = () => Date.now();  // the wall clock, as the host's stamps (a monotonic clock drifts from it)
  const d = window.fringe3dDisplay = {frame: [], arrival: [], received: [], drawn: [], tick: [], latency: [],
                                      summary: null, acknowledged: 'field'};
  const box = document.createElement('div');
  box.id = '%(figures)s';
  box.style.cssText = 'position:fixed;left:8px;bottom:8px;z-index:1000;font:12px monospace;color:#222;' +
    'background:rgba(255,255,255,0.85);padding:3px 6px;border-radius:4px;pointer-events:none;white-space:pre';
  box.textContent = 'in this page: waiting for 3D frames';
  const style = document.createElement('style');  // a depth frame's stamp is its image: drawn in a canvas instead
  style.textContent = 'img[%(frame)s] { display: none !important; }';
  document.head.appendChild(style);
  document.body.appendChild(box);
  const quantile = (sorted, q) => {
    const h = (sorted.length - 1) * q, i = Math.floor(h), j = Math.min(i + 1, sorted.length - 1);
    return sorted[i] + (h - i) * (sorted[j] - sorted[i]);
  };
  const round = x => Math.round(x * 10) / 10;
  const update = () => {
    const n = d.drawn.length, s = [...d.latency].sort((a, b) => a - b);
    const fps = n > 1 && d.tick[n - 1] > d.tick[0] ? (n - 1) / ((d.tick[n - 1] - d.tick[0]) / 1000) : 0;
    d.summary = {frames_drawn: n, last_frame: d.frame[n - 1], fps: round(fps), acknowledged: d.acknowledged,
                 latency_ms: {median: round(quantile(s, 0.5)), p95: round(quantile(s, 0.95)), max: round(s[n - 1])}};
    const l = d.summary.latency_ms;
    box.textContent = `in this page: ${n} 3D frames drawn, ${d.summary.fps.toFixed(1)} frames/s; ` +
      `display latency (arrival to drawn) median ${l.median.toFixed(1)} ms, p95 ${l.p95.toFixed(1)} ms, ` +
      `max ${l.max.toFixed(1)} ms`;
  };
  let last = null, pending = null, scheduled = false, timer = null;
  const setter = Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, 'value').set;
  let ackInput = null, ackWorker = null, ackUuid = null, typing = false;
  // the field's update as typed goes through viser's websocket worker: seen once, it is sent there directly
  // (no React update of the hidden field, no 50 ms throttle of typed values)
  const post = Worker.prototype.postMessage;
  Worker.prototype.postMessage = function (data, ...rest) {
    const m = data && data.type === 'send' ? data.message : null;
    if (typing && m && m.type === 'GuiUpdateMessage' && m.updates && 'value' in m.updates) {
      ackWorker = this; ackUuid = m.uuid; d.acknowledged = 'worker';
    }
    return post.call(this, data, ...rest);
  };
  const acknowledge = frame => {  // tell the server (a GUI text field, as if typed): it paces the clouds
    if (ackWorker !== null) {
      post.call(ackWorker, {type: 'send', message: {type: 'GuiUpdateMessage', uuid: ackUuid,
                                                     updates: {value: String(frame)}}});
      return true;
    }
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
    typing = true;
    try { ackInput.dispatchEvent(new Event('input', {bubbles: true})); } finally { typing = false; }
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
  let view = 'cloud', token = 0, depthCanvas = null, onCanvas = 0, depthPending = null, depthScheduled = false;
  const layOut = () => {  // the depth canvas over the 3D view, the 3D canvas hidden (or back)
    const canvas = [...document.querySelectorAll('canvas')].find(c => c !== depthCanvas);
    if (depthCanvas) {
      const r = canvas ? canvas.parentElement.getBoundingClientRect()  // its box (kept while it is hidden)
                       : {left: 0, top: 0, width: innerWidth, height: innerHeight};
      // at the image's own size (a scaled image costs the software rasteriser more per frame), centred
      const w = depthCanvas.width, h = depthCanvas.height;
      Object.assign(depthCanvas.style, {left: Math.max(r.left, r.left + (r.width - w) / 2) + 'px',
                                        top: Math.max(r.top, r.top + (r.height - h) / 2) + 'px',
                                        display: view === 'depth' ? '' : 'none'});
    }
    if (canvas) canvas.style.display = view === 'depth' ? 'none' : '';
  };
  // a depth frame (its stamp is the image, a hidden <img> with a data: URL): decoded off the main thread
  // (an Image of the data: URL and its decode(): no Blob, no bytes copied by script), drawn into the page's
  // own canvas, then timed as a cloud is
  const showDepth = (p, src) => {
    if (view !== 'depth') { view = 'depth'; ++token; layOut(); }
    const mine = token;
    const img = new Image();
    img.src = src;
    img.decode().then(() => img).then(image => {
      // a view change since, or a newer frame drawn already (decoded first): this one is not shown
      if (mine !== token || p.frame <= onCanvas) return;
      if (!depthCanvas) {
        depthCanvas = document.createElement('canvas');
        depthCanvas.id = '%(depth_canvas)s';
        depthCanvas.style.cssText = 'position:fixed;z-index:900;pointer-events:none';
        document.body.appendChild(depthCanvas);
        addEventListener('resize', layOut);  // laid out again when the page or the 3D view's box changes size
        const canvas = [...document.querySelectorAll('canvas')].find(c => c !== depthCanvas);
        if (canvas && canvas.parentElement) new ResizeObserver(layOut).observe(canvas.parentElement);
      }
      if (depthCanvas.width !== image.width || depthCanvas.height !== image.height) {
        depthCanvas.width = image.width;
        depthCanvas.height = image.height;
        layOut();  // not per frame: reading the 3D view's box forces a layout of the page
      }
      depthCanvas.getContext('2d').drawImage(image, 0, 0);
      onCanvas = p.frame;
      depthPending = p;
      if (depthScheduled) return;  // drawn again before the next animation frame: only the newer is shown
      depthScheduled = true;
      // the next animation frame shows the canvas; the task after it runs once it is shown
      requestAnimationFrame(() => setTimeout(() => {
        const q = depthPending;
        depthPending = null;
        depthScheduled = false;
        if (q && mine === token) drawn(q, now());
      }, 0));
    }, () => {});
  };
  const look = () => {
    const el = document.querySelector('[%(frame)s]');
    if (!el) return;
    const frame = Number(el.getAttribute('%(frame)s'));
    if (frame === last || frame < 1) return;  // frame 0: the stamp before the first cloud
    last = frame;
    const stamp = {frame, arrival: Number(el.getAttribute('%(arrival)s')), received: now()};
    if (el.tagName === 'IMG') { showDepth(stamp, el.getAttribute('src') || ''); return; }
    if (view !== 'cloud') { view = 'cloud'; ++token; layOut(); }  // depth frames still decoding are not shown
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
  new MutationObserver(look).observe(document.body, {subtree: true, childList: true});
  hello();
  look();
})();
""" % {"ack": ACK_LABEL, "figures": FIGURES_ID, "frame": FRAME_ATTRIBUTE, "arrival": ARRIVAL_ATTRIBUTE,
       "depth_canvas": DEPTH_CANVAS_ID}


def frame_stamp(frame: int, arrival_ms: float, jpeg: bytes | None = None) -> str:
    """The stamp element sent with a frame: in the cloud view with its cloud, in the depth view it
    is the frame (its image inline).

    Parameters
    ----------
    frame : int
        The frame's number (1 for the first shown).
    arrival_ms : float
        Host time its cycle's last camera frame arrived (ms since the epoch).
    jpeg : bytes, optional
        The depth image, JPEG-encoded (the depth view).

    Returns
    -------
    str
        An empty ``<span>`` carrying the two as attributes, or, with ``jpeg``, an ``<img>`` with
        them and the image as a ``data:`` URL (a page without :data:`SCRIPT` shows it as it is).
    """
    stamp = f'{FRAME_ATTRIBUTE}="{int(frame)}" {ARRIVAL_ATTRIBUTE}="{float(arrival_ms):.3f}"'
    if jpeg is None:
        return f"<span {stamp}></span>"
    # lazy: a browser need not load an image it does not show (the page script hides it)
    return f'<img {stamp} loading="lazy" src="data:image/jpeg;base64,{base64.b64encode(bytes(jpeg)).decode("ascii")}">'
