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
  const acknowledge = frame => {  // tell the server (a GUI text field, as if typed): it paces the clouds
    const label = [...document.querySelectorAll('label, p, span, div')].filter(
      e => e.textContent.trim() === '%(ack)s').pop();
    let row = label;
    while (row && !row.querySelector('input')) row = row.parentElement;
    const input = row && row.querySelector('input');
    if (!input) return false;
    row.style.display = 'none';  // the page's own field, not a control
    setter.call(input, String(frame));
    input.dispatchEvent(new Event('input', {bubbles: true}));
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
  const look = () => {
    const el = document.querySelector('[%(frame)s]');
    if (!el) return;
    const frame = Number(el.getAttribute('%(frame)s'));
    if (frame === last || frame < 1) return;  // frame 0: the stamp before the first cloud
    last = frame;
    pending = {frame, arrival: Number(el.getAttribute('%(arrival)s')), received: now()};
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
""" % {"ack": ACK_LABEL, "figures": FIGURES_ID, "frame": FRAME_ATTRIBUTE, "arrival": ARRIVAL_ATTRIBUTE}


def frame_stamp(frame: int, arrival_ms: float) -> str:
    """The stamp element sent with a frame's cloud.

    Parameters
    ----------
    frame : int
        The frame's number (1 for the first shown).
    arrival_ms : float
        Host time its cycle's last camera frame arrived (ms since the epoch).

    Returns
    -------
    str
        An empty ``<span>`` carrying both as attributes.
    """
    return f'<span {FRAME_ATTRIBUTE}="{int(frame)}" {ARRIVAL_ATTRIBUTE}="{arrival_ms:.3f}"></span>'
