// Time range of the report's plots: drag across a plot to zoom every plot to
// that time range, double-click or "whole program" to zoom out, type a range,
// or open the page at #t=A,B (a range) or #t=T (a window around T). The range
// shown is in #plot-range's data-range ("A,B", s).
(function () {
  var plots = Array.prototype.slice.call(document.querySelectorAll('svg.plot[data-t0]'));
  var bar = document.getElementById('plot-range');
  if (!plots.length || !bar) return;
  var NS = 'http://www.w3.org/2000/svg';
  var from = document.getElementById('range-from');
  var to = document.getElementById('range-to');
  var T0 = Infinity, T1 = -Infinity;
  plots.forEach(function (p) {
    T0 = Math.min(T0, +p.dataset.t0);
    T1 = Math.max(T1, +p.dataset.t1);
  });
  var shown = [T0, T1];

  function niceStep(raw) {
    var mag = Math.pow(10, Math.floor(Math.log10(raw)));
    var f = raw / mag;
    return (f <= 1 ? 1 : f <= 2 ? 2 : f <= 5 ? 5 : 10) * mag;
  }
  function tickLabel(v, step) {
    var mag = Math.max(Math.abs(v), step);
    if (mag !== 0 && (mag < 1e-3 || mag >= 1e6)) return v.toExponential(1);
    return v.toFixed(Math.min(12, Math.max(0, -Math.floor(Math.log10(step)))));
  }
  function el(name, attrs, text) {
    var e = document.createElementNS(NS, name);
    for (var k in attrs) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    return e;
  }
  function draw(p, a, b) {
    var t0 = +p.dataset.t0, t1 = +p.dataset.t1;
    var x = +p.dataset.x, w = +p.dataset.w, y = +p.dataset.y, h = +p.dataset.h;
    // Series drawn over t0..t1 onto x..x+w, shown over a..b: x' = k·x + c.
    var k = (t1 - t0) / (b - a);
    var c = x * (1 - k) - k * w * (a - t0) / (t1 - t0);
    p.querySelector('g.zoom').setAttribute('transform', 'matrix(' + k + ' 0 0 1 ' + c + ' 0)');
    var g = p.querySelector('g.xticks');
    while (g.firstChild) g.removeChild(g.firstChild);
    var step = niceStep((b - a) / 8);
    for (var i = Math.ceil(a / step); i * step <= b + 1e-9 * step; i++) {
      var v = Math.abs(i * step) < 1e-9 * step ? 0 : i * step;
      var px = (x + (v - a) / (b - a) * w).toFixed(1);
      g.appendChild(el('line', { x1: px, y1: y, x2: px, y2: y + h, stroke: '#e6e6e6' }));
      g.appendChild(el('line', { x1: px, y1: y + h, x2: px, y2: y + h + 5, stroke: '#333' }));
      g.appendChild(el('text', { x: px, y: y + h + 18, 'text-anchor': 'middle' }, tickLabel(v, step)));
    }
  }
  function zoom(a, b) {
    a = Math.max(T0, a);
    b = Math.min(T1, b);
    if (!(b > a)) { a = T0; b = T1; }
    shown = [a, b];
    plots.forEach(function (p) { draw(p, a, b); });
    from.value = +a.toPrecision(6);
    to.value = +b.toPrecision(6);
    bar.dataset.range = a + ',' + b;
  }
  // Plot x (viewBox units) of a mouse event, and the time shown there.
  function plotX(p, e) {
    var r = p.getBoundingClientRect();
    return (e.clientX - r.left) * p.viewBox.baseVal.width / r.width;
  }
  function timeAt(p, x) {
    var f = (x - +p.dataset.x) / +p.dataset.w;
    return shown[0] + Math.min(1, Math.max(0, f)) * (shown[1] - shown[0]);
  }
  plots.forEach(function (p) {
    var brush = p.querySelector('rect.brush'), start = null;
    p.addEventListener('mousedown', function (e) {
      start = Math.min(Math.max(plotX(p, e), +p.dataset.x), +p.dataset.x + +p.dataset.w);
      brush.setAttribute('x', start);
      brush.setAttribute('width', 0);
      brush.setAttribute('visibility', 'visible');
      e.preventDefault();
    });
    p.addEventListener('mousemove', function (e) {
      if (start === null) return;
      var x = Math.min(Math.max(plotX(p, e), +p.dataset.x), +p.dataset.x + +p.dataset.w);
      brush.setAttribute('x', Math.min(start, x));
      brush.setAttribute('width', Math.abs(x - start));
    });
    window.addEventListener('mouseup', function (e) {
      if (start === null) return;
      var x = plotX(p, e), a = timeAt(p, Math.min(start, x)), b = timeAt(p, Math.max(start, x));
      var dragged = Math.abs(x - start) > 4;
      brush.setAttribute('visibility', 'hidden');
      start = null;
      if (dragged && b > a) zoom(a, b);
    });
    p.addEventListener('dblclick', function () { zoom(T0, T1); });
  });
  function fromHash() {
    var m = /^#t=([-+0-9.eE]+)(?:,([-+0-9.eE]+))?$/.exec(location.hash);
    if (!m) return;
    var a = +m[1];
    if (m[2] !== undefined) {
      zoom(a, +m[2]);
    } else {
      var half = (T1 - T0) / 40;
      zoom(a - half, a + half);
    }
    bar.scrollIntoView();
  }
  from.addEventListener('change', function () { zoom(+from.value, +to.value); });
  to.addEventListener('change', function () { zoom(+from.value, +to.value); });
  document.getElementById('range-reset').addEventListener('click', function () { zoom(T0, T1); });
  window.addEventListener('hashchange', fromHash);
  zoom(T0, T1);
  fromHash();
})();
