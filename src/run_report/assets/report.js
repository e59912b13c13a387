// femu run report: the FRF viewer (with posterior predictive bands), the updating history, the
// 3-D mesh viewer (with test points) and the posterior intervals, drawn on canvases from the
// JSON inlined in the page. No network, no libraries.
(function () {
  'use strict';
  var errors = [];
  function fail(message) {
    errors.push(String(message));
    var box = document.getElementById('report-errors');
    box.hidden = false;
    box.textContent = 'The report script failed: ' + errors.join('; ');
    document.body.setAttribute('data-rendered', 'error');
  }
  window.addEventListener('error', function (e) { fail(e.message); });

  var COLOURS = ['#1f77b4', '#d62728', '#2ca02c', '#ff7f0e', '#9467bd', '#8c564b', '#e377c2', '#17becf', '#7f7f7f', '#bcbd22'];

  function el(tag, attrs, parent) {
    var e = document.createElement(tag);
    Object.keys(attrs || {}).forEach(function (k) {
      if (k === 'text') { e.textContent = attrs[k]; } else { e.setAttribute(k, attrs[k]); }
    });
    if (parent) { parent.appendChild(e); }
    return e;
  }

  function fmt(v) {
    if (v === 0) { return '0'; }
    var a = Math.abs(v);
    if (a >= 1e-3 && a < 1e5) { return String(Math.round(v * 1e4) / 1e4); }
    return v.toExponential(2).replace(/\.?0+e/, 'e');
  }

  function linearTicks(lo, hi) {
    var span = hi - lo;
    if (!(span > 0)) { return [lo]; }
    var step = Math.pow(10, Math.floor(Math.log10(span / 5)));
    var m = span / 5 / step;
    step *= m >= 5 ? 5 : m >= 2 ? 2 : 1;
    // Ticks by an integer count: a span below the values' own rounding (a flat history) would
    // never advance `t += step`.
    var first = Math.ceil(lo / step), count = Math.floor(hi / step + 1e-9) - first + 1;
    if (!(count >= 1 && count <= 50) || lo + step === lo) { return [lo, hi]; }
    var out = [];
    for (var k = 0; k < count; k++) {
      var t = (first + k) * step;
      out.push(Math.abs(t) < step * 1e-9 ? 0 : t);
    }
    return out;
  }

  function logTicks(lo, hi) {
    var out = [];
    var a = Math.floor(Math.log10(lo)), b = Math.ceil(Math.log10(hi));
    var every = Math.max(1, Math.ceil((b - a) / 8));
    for (var e = a; e <= b; e += every) {
      var t = Math.pow(10, e);
      if (t >= lo * 0.999 && t <= hi * 1.001) { out.push(t); }
    }
    if (out.length < 2) { return linearTicks(lo, hi); }
    return out;
  }

  // A 2-D line plot on a canvas. Plots of one group share the frequency range: a drag zooms
  // every plot of the group, a double-click resets it.
  function Group() { this.plots = []; this.xrange = null; }
  Group.prototype.set = function (r) { this.xrange = r; this.plots.forEach(function (p) { p.draw(); }); };

  function Plot(parent, opts, group) {
    this.opts = opts;
    this.group = group || new Group();
    this.group.plots.push(this);
    this.series = [];
    this.canvas = el('canvas', { height: String(opts.height || 260), 'aria-label': opts.ylabel || 'plot' }, parent);
    this.readout = el('div', { 'class': 'readout' }, parent);
    var self = this;
    var start = null;
    this.canvas.addEventListener('mousedown', function (e) { start = self.pos(e).x; });
    this.canvas.addEventListener('mousemove', function (e) {
      var p = self.pos(e);
      var x = self.invx(p.x);
      self.readout.textContent = isFinite(x) ? (self.opts.xlabel || 'x') + ' = ' + fmt(x) : '';
      if (start !== null) { self.draw(); self.band(start, p.x); }
    });
    this.canvas.addEventListener('mouseup', function (e) {
      if (start === null) { return; }
      var end = self.pos(e).x;
      var a = Math.min(start, end), b = Math.max(start, end);
      start = null;
      if (b - a > 5) { self.group.set([self.invx(a), self.invx(b)]); } else { self.draw(); }
    });
    this.canvas.addEventListener('dblclick', function () { self.group.set(null); });
  }
  Plot.prototype.pos = function (e) {
    var r = this.canvas.getBoundingClientRect();
    return { x: e.clientX - r.left, y: e.clientY - r.top };
  };
  Plot.prototype.frame = function () {
    var w = Math.max(320, this.canvas.clientWidth || 900), h = this.opts.height || 260;
    return { w: w, h: h, l: 74, r: 12, t: 10, b: 40 };
  };
  Plot.prototype.invx = function (px) {
    var f = this.frame(), s = this.scale;
    if (!s) { return NaN; }
    var u = (px - f.l) / (f.w - f.l - f.r);
    return this.opts.xlog() ? Math.pow(10, s.x0 + u * (s.x1 - s.x0)) : s.x0 + u * (s.x1 - s.x0);
  };
  Plot.prototype.band = function (a, b) {
    var c = this.canvas.getContext('2d'), f = this.frame();
    c.fillStyle = 'rgba(31,95,168,0.15)';
    c.fillRect(Math.min(a, b), f.t, Math.abs(b - a), f.h - f.t - f.b);
  };
  Plot.prototype.draw = function () {
    var f = this.frame(), dpr = window.devicePixelRatio || 1;
    var cv = this.canvas;
    cv.width = Math.round(f.w * dpr);
    cv.height = Math.round(f.h * dpr);
    cv.style.height = f.h + 'px';
    var c = cv.getContext('2d');
    c.setTransform(dpr, 0, 0, dpr, 0, 0);
    c.clearRect(0, 0, f.w, f.h);
    var xlog = this.opts.xlog(), ylog = this.opts.ylog ? this.opts.ylog() : false;
    var xr = this.group.xrange;
    var x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    this.series.forEach(function (s) {
      for (var i = 0; i < s.x.length; i++) {
        var x = s.x[i], y = s.y[i];
        if (x === null || y === null || (xlog && !(x > 0)) || (ylog && !(y > 0))) { continue; }
        if (xr && (x < xr[0] || x > xr[1])) { continue; }
        x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y);
      }
    });
    if (xr) { x0 = xr[0]; x1 = xr[1]; if (xlog && !(x0 > 0)) { x0 = x1 / 1e3; } }
    if (this.opts.yfix) { y0 = this.opts.yfix[0]; y1 = this.opts.yfix[1]; }
    if (!isFinite(x0) || !isFinite(y0)) {
      c.fillStyle = '#5d6677';
      c.fillText('nothing to draw for this choice', f.l + 10, f.t + 20);
      this.scale = null;
      return;
    }
    if (x1 === x0) { x1 = x0 + 1; }
    if (y1 === y0) { y0 -= ylog ? y0 * 0.5 : 1; y1 += ylog ? y1 : 1; }
    var X = function (v) { return xlog ? Math.log10(v) : v; }, Y = function (v) { return ylog ? Math.log10(v) : v; };
    var s = { x0: X(x0), x1: X(x1), y0: Y(y0), y1: Y(y1) };
    if (!ylog && !this.opts.yfix) { var pad = 0.04 * (s.y1 - s.y0); s.y0 -= pad; s.y1 += pad; }
    this.scale = s;
    var pw = f.w - f.l - f.r, ph = f.h - f.t - f.b;
    var tx = function (v) { return f.l + (X(v) - s.x0) / (s.x1 - s.x0) * pw; };
    var ty = function (v) { return f.t + ph - (Y(v) - s.y0) / (s.y1 - s.y0) * ph; };
    c.font = '11px system-ui, sans-serif';
    c.strokeStyle = '#e3e6eb'; c.fillStyle = '#1d2330'; c.lineWidth = 1;
    (xlog ? logTicks(x0, x1) : linearTicks(x0, x1)).forEach(function (t) {
      var px = tx(t);
      c.beginPath(); c.moveTo(px, f.t); c.lineTo(px, f.t + ph); c.stroke();
      c.textAlign = 'center'; c.fillText(fmt(t), px, f.t + ph + 14);
    });
    (ylog ? logTicks(Math.pow(10, s.y0), Math.pow(10, s.y1)) : linearTicks(s.y0, s.y1)).forEach(function (t) {
      var py = ty(t);
      c.beginPath(); c.moveTo(f.l, py); c.lineTo(f.l + pw, py); c.stroke();
      c.textAlign = 'right'; c.fillText(fmt(t), f.l - 5, py + 4);
    });
    c.strokeStyle = '#5d6677'; c.strokeRect(f.l, f.t, pw, ph);
    c.textAlign = 'center';
    c.fillText(this.opts.xlabel || '', f.l + pw / 2, f.h - 6);
    c.save(); c.translate(13, f.t + ph / 2); c.rotate(-Math.PI / 2); c.fillText(this.opts.ylabel || '', 0, 0); c.restore();
    c.save();
    c.beginPath(); c.rect(f.l, f.t, pw, ph); c.clip();
    this.series.forEach(function (se) {
      c.strokeStyle = se.colour; c.lineWidth = se.width || 1.4;
      c.setLineDash(se.dash || []);
      c.beginPath();
      var pen = false;
      for (var i = 0; i < se.x.length; i++) {
        var x = se.x[i], y = se.y[i];
        if (x === null || y === null || (xlog && !(x > 0)) || (ylog && !(y > 0))) { pen = false; continue; }
        var px = tx(x), py = ty(y);
        if (pen) { c.lineTo(px, py); } else { c.moveTo(px, py); pen = true; }
      }
      c.stroke();
    });
    c.restore();
    c.setLineDash([]);
    var ly = f.t + 14;
    c.textAlign = 'left';
    this.series.forEach(function (se) {
      c.fillStyle = 'rgba(255,255,255,0.85)';
      c.fillRect(f.l + pw - 230, ly - 11, 226, 15);
      c.strokeStyle = se.colour; c.lineWidth = 2; c.setLineDash(se.dash || []);
      c.beginPath(); c.moveTo(f.l + pw - 226, ly - 4); c.lineTo(f.l + pw - 204, ly - 4); c.stroke();
      c.setLineDash([]);
      c.fillStyle = '#1d2330'; c.fillText(se.name, f.l + pw - 198, ly);
      ly += 15;
    });
  };

  function select(parent, label, options, onchange) {
    var l = el('label', { text: label + ' ' }, parent);
    var s = el('select', {}, l);
    options.forEach(function (o) { el('option', { value: o[0], text: o[1] }, s); });
    s.addEventListener('change', onchange);
    return s;
  }

  function frfViewer(root, data) {
    var controls = el('div', { 'class': 'controls' }, root);
    var labels = [];
    data.frfs.forEach(function (f) { f.pairs.forEach(function (p) { if (labels.indexOf(p.label) < 0) { labels.push(p.label); } }); });
    var pair = select(controls, 'FRF', labels.map(function (l) { return [l, l]; }), redraw);
    var xscale = select(controls, 'frequency axis', [['log', 'logarithmic'], ['lin', 'linear']], redraw);
    var shown = {};
    data.frfs.forEach(function (f, i) {
      var l = el('label', {}, controls);
      var box = el('input', { type: 'checkbox', checked: 'checked' }, l);
      l.appendChild(document.createTextNode(' ' + f.id));
      shown[f.id] = box;
      box.addEventListener('change', redraw);
      if (f.omitted_pairs > 0) {
        el('span', { 'class': 'note', text: '(' + f.omitted_pairs + ' more FRFs in ' + f.id + ' not drawn)' }, controls);
      }
      f.colour = COLOURS[i % COLOURS.length];
    });
    var frac = el('div', { 'class': 'readout' }, root);
    var group = new Group();
    var xlog = function () { return xscale.value === 'log'; };
    var unit = data.frfs.length ? data.frfs[0].unit : '';
    var mag = new Plot(root, { xlabel: 'frequency (Hz)', ylabel: '|H| (' + unit + ')', xlog: xlog, ylog: function () { return true; } }, group);
    var phase = new Plot(root, { height: 170, xlabel: 'frequency (Hz)', ylabel: 'phase (deg)', xlog: xlog, yfix: [-180, 180] }, group);
    var chi = data.correlations.length ? new Plot(root, { height: 200, xlabel: 'frequency (Hz)', ylabel: 'χ (4.8, 4.9)', xlog: xlog, yfix: [0, 1] }, group) : null;
    function redraw() {
      var label = pair.value;
      mag.series = []; phase.series = [];
      data.frfs.forEach(function (f) {
        if (!shown[f.id].checked) { return; }
        var p = f.pairs.find(function (q) { return q.label === label; });
        if (!p) { return; }
        var m = [], ph = [];
        for (var k = 0; k < f.freqs.length; k++) {
          var re = p.re[k], im = p.im[k];
          if (re === null || im === null) { m.push(null); ph.push(null); continue; }
          m.push(Math.hypot(re, im));
          ph.push(Math.atan2(im, re) * 180 / Math.PI);
        }
        mag.series.push({ name: f.id, colour: f.colour, x: f.freqs, y: m });
        phase.series.push({ name: f.id, colour: f.colour, x: f.freqs, y: ph });
      });
      (data.posteriors || []).forEach(function (po) {
        var b = po.bands.find(function (q) { return q.pair === label; });
        if (!b) { return; }
        mag.series.push({ name: po.id + ' − 2 sd', colour: '#7f7f7f', x: b.freqs, y: b.lower, dash: [3, 3], width: 1 });
        mag.series.push({ name: po.id + ' + 2 sd', colour: '#7f7f7f', x: b.freqs, y: b.upper, dash: [3, 3], width: 1 });
      });
      var notes = [];
      if (chi) {
        chi.series = [];
        data.correlations.forEach(function (c, i) {
          chi.series.push({ name: 'χ_s ' + c.id, colour: COLOURS[(2 * i) % COLOURS.length], x: c.freqs, y: c.chi_s });
          chi.series.push({ name: 'χ_a ' + c.id, colour: COLOURS[(2 * i + 1) % COLOURS.length], x: c.freqs, y: c.chi_a, dash: [5, 3] });
          c.frac.forEach(function (fr) { if (fr[0] === label && fr[1] !== null) { notes.push('FRAC ' + c.id + ' = ' + fmt(fr[1])); } });
        });
      }
      frac.textContent = notes.join(' · ');
      group.set(group.xrange);
    }
    redraw();
    root.setAttribute('data-ready', '1');
  }

  function updateViewer(root, data) {
    data.updates.forEach(function (u) {
      el('h3', { text: u.id + ': parameters relative to their start, and mean correlation' }, root);
      var lin = function () { return false; };
      var p = new Plot(root, { height: 240, xlabel: 'iteration', ylabel: 'value / initial', xlog: lin });
      p.series = u.parameters.map(function (name, i) {
        return { name: name, colour: COLOURS[i % COLOURS.length], x: u.iterations, y: u.relative[i] };
      });
      p.draw();
      var c = new Plot(root, { height: 200, xlabel: 'iteration', ylabel: 'mean χ', xlog: lin, yfix: [0, 1] });
      c.series = [
        { name: 'mean χ_s', colour: COLOURS[0], x: u.iterations, y: u.mean_chi_s },
        { name: 'mean χ_a', colour: COLOURS[1], x: u.iterations, y: u.mean_chi_a, dash: [5, 3] }
      ];
      c.draw();
    });
    root.setAttribute('data-ready', '1');
  }

  // Sequential colour ramp (dark blue to yellow), t in [0, 1].
  function ramp(t) {
    var stops = [[48, 18, 59], [70, 107, 227], [40, 187, 236], [50, 241, 151], [164, 252, 60], [250, 186, 57], [230, 78, 14], [122, 4, 3]];
    t = Math.max(0, Math.min(1, t)) * (stops.length - 1);
    var i = Math.min(stops.length - 2, Math.floor(t)), u = t - i;
    var a = stops[i], b = stops[i + 1];
    return [0, 1, 2].map(function (k) { return Math.round(a[k] + (b[k] - a[k]) * u); });
  }

  function meshViewer(root, data) {
    var controls = el('div', { 'class': 'controls' }, root);
    var choices = [];
    data.fields.forEach(function (f, i) { choices.push(['f' + i, f.id + ' on ' + f.mesh]); });
    (data.test_points || []).forEach(function (t, i) { if (t.mesh) { choices.push(['t' + i, 'test points of ' + t.id + ' on ' + t.mesh]); } });
    data.meshes.forEach(function (m, i) { choices.push(['m' + i, m.id + ' (geometry)']); });
    var pick = select(controls, 'show', choices, function () { reset(); draw(); });
    var canvas = el('canvas', { height: '520', 'aria-label': 'mesh' }, root);
    var readout = el('div', { 'class': 'readout' }, root);
    var state = { az: -0.6, el: 0.5, zoom: 1 };
    var mesh, field, points, items = [], markers = [];
    function reset() {
      var v = pick.value, k = Number(v.slice(1));
      field = v[0] === 'f' ? data.fields[k] : null;
      points = v[0] === 't' ? data.test_points[k] : null;
      var on = field ? field.mesh : points ? points.mesh : null;
      mesh = on ? data.meshes.find(function (m) { return m.id === on; }) : data.meshes[k];
    }
    // A test point's colour: its pairing distance on the scale up to the tolerance (or the
    // largest distance when none is recorded).
    function pointScale(t) {
      var top = t.tolerance_m || 0;
      if (!(top > 0)) { t.points.forEach(function (p) { if (p.distance_m !== null) { top = Math.max(top, p.distance_m); } }); }
      return top > 0 ? top : 1;
    }
    function describe(p) {
      var to = p.fe_node !== null ? 'node ' + p.fe_node : p.fe_element !== null ? 'element ' + p.fe_element : 'nothing';
      return 'test point ' + p.node + ' → ' + to + ' · distance ' + (p.distance_m === null ? '—' : fmt(p.distance_m * 1e3) + ' mm') + (p.status === 'ok' ? '' : ' · ' + p.status);
    }
    function basis() {
      var ca = Math.cos(state.az), sa = Math.sin(state.az), ce = Math.cos(state.el), se = Math.sin(state.el);
      return { right: [-sa, ca, 0], up: [-se * ca, -se * sa, ce], toward: [ce * ca, ce * sa, se] };
    }
    function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
    function draw() {
      var w = Math.max(320, canvas.clientWidth || 900), h = 520, dpr = window.devicePixelRatio || 1;
      canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr); canvas.style.height = h + 'px';
      var c = canvas.getContext('2d');
      c.setTransform(dpr, 0, 0, dpr, 0, 0);
      c.clearRect(0, 0, w, h);
      items = [];
      if (!mesh || !mesh.faces.length) {
        c.fillStyle = '#5d6677'; c.fillText('no drawable elements', 20, 30);
        return;
      }
      var xyz = mesh.xyz, n = xyz.length / 3, b = basis();
      var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
      for (var i = 0; i < n; i++) { for (var k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], xyz[3 * i + k]); hi[k] = Math.max(hi[k], xyz[3 * i + k]); } }
      var mid = [0, 1, 2].map(function (k) { return (lo[k] + hi[k]) / 2; });
      var radius = Math.max(1e-12, Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) / 2);
      var scale = state.zoom * 0.45 * Math.min(w - 90, h) / radius;
      var cx = (w - 90) / 2, cy = h / 2;
      var proj = function (i) {
        var p = [xyz[3 * i] - mid[0], xyz[3 * i + 1] - mid[1], xyz[3 * i + 2] - mid[2]];
        return [cx + scale * dot(p, b.right), cy - scale * dot(p, b.up), dot(p, b.toward)];
      };
      var P = new Array(n);
      for (i = 0; i < n; i++) { P[i] = proj(i); }
      var projectPoint = function (q) {
        var p = [q[0] - mid[0], q[1] - mid[1], q[2] - mid[2]];
        return [cx + scale * dot(p, b.right), cy - scale * dot(p, b.up)];
      };
      var top = 0;
      if (field) { Object.keys(field.values).forEach(function (e) { top = Math.max(top, field.values[e]); }); }
      for (i = 0; i < mesh.faces.length; i++) {
        var f = mesh.faces[i], depth = 0;
        var pts = f.map(function (k) { depth += P[k][2]; return P[k]; });
        items.push({ e: mesh.face_element[i], pts: pts, depth: depth / f.length, nodes: f });
      }
      items.sort(function (a, b2) { return a.depth - b2.depth; });
      items.forEach(function (it) {
        var v = field ? field.values[String(it.e)] : undefined;
        var rgb = v === undefined ? [205, 210, 218] : ramp(top > 0 ? v / top : 0);
        c.beginPath();
        it.pts.forEach(function (p, j) { if (j) { c.lineTo(p[0], p[1]); } else { c.moveTo(p[0], p[1]); } });
        if (it.pts.length > 2) {
          var a = it.nodes, u = [0, 1, 2].map(function (k) { return xyz[3 * a[1] + k] - xyz[3 * a[0] + k]; });
          var q = [0, 1, 2].map(function (k) { return xyz[3 * a[2] + k] - xyz[3 * a[0] + k]; });
          var nrm = [u[1] * q[2] - u[2] * q[1], u[2] * q[0] - u[0] * q[2], u[0] * q[1] - u[1] * q[0]];
          var len = Math.hypot(nrm[0], nrm[1], nrm[2]) || 1;
          var shade = 0.55 + 0.45 * Math.abs(dot(nrm, b.toward)) / len;
          c.closePath();
          c.fillStyle = 'rgb(' + rgb.map(function (x) { return Math.round(x * shade); }).join(',') + ')';
          c.fill();
          c.strokeStyle = 'rgba(30,35,48,0.35)'; c.lineWidth = 0.6; c.stroke();
        } else {
          c.strokeStyle = 'rgb(' + (v === undefined ? [60, 70, 90] : rgb).join(',') + ')'; c.lineWidth = 2.2; c.stroke();
        }
      });
      markers = [];
      if (points) {
        var tol = pointScale(points);
        points.points.forEach(function (p) {
          var at = projectPoint(p.xyz);
          if (!isFinite(at[0]) || !isFinite(at[1])) { return; }
          var rgb = ramp(p.distance_m === null ? 1 : p.distance_m / tol);
          if (p.status !== 'ok') {
            c.strokeStyle = '#d62728'; c.lineWidth = 2.5;
            c.beginPath(); c.arc(at[0], at[1], 9, 0, 2 * Math.PI); c.stroke();
          }
          c.fillStyle = 'rgb(' + rgb.join(',') + ')';
          c.beginPath(); c.arc(at[0], at[1], 5.5, 0, 2 * Math.PI); c.fill();
          c.strokeStyle = '#1d2330'; c.lineWidth = 1; c.stroke();
          markers.push({ x: at[0], y: at[1], p: p });
        });
        canvas.setAttribute('data-test-points', String(markers.length));
        var px0 = w - 60, py0 = 30, ph0 = h - 80;
        for (var s2 = 0; s2 < 100; s2++) {
          c.fillStyle = 'rgb(' + ramp(1 - s2 / 99).join(',') + ')';
          c.fillRect(px0, py0 + s2 * ph0 / 100, 16, ph0 / 100 + 1);
        }
        c.fillStyle = '#1d2330'; c.font = '11px system-ui, sans-serif'; c.textAlign = 'left';
        c.fillText(fmt(tol * 1e3), px0 + 20, py0 + 8); c.fillText('0', px0 + 20, py0 + ph0);
        c.save(); c.translate(px0 - 8, py0 + ph0 / 2); c.rotate(-Math.PI / 2); c.textAlign = 'center';
        c.fillText('pairing distance (mm)', 0, 0); c.restore();
      }
      // Orientation triad.
      var o = [46, h - 46];
      [['x', [1, 0, 0], '#d62728'], ['y', [0, 1, 0], '#2ca02c'], ['z', [0, 0, 1], '#1f77b4']].forEach(function (ax) {
        var ex = o[0] + 30 * dot(ax[1], b.right), ey = o[1] - 30 * dot(ax[1], b.up);
        c.strokeStyle = ax[2]; c.lineWidth = 2; c.beginPath(); c.moveTo(o[0], o[1]); c.lineTo(ex, ey); c.stroke();
        c.fillStyle = ax[2]; c.font = 'bold 12px system-ui, sans-serif'; c.fillText(ax[0], ex + 3, ey + 3);
      });
      if (field) {
        var bx = w - 60, by0 = 30, bh = h - 80;
        for (var s = 0; s < 100; s++) {
          c.fillStyle = 'rgb(' + ramp(1 - s / 99).join(',') + ')';
          c.fillRect(bx, by0 + s * bh / 100, 16, bh / 100 + 1);
        }
        c.fillStyle = '#1d2330'; c.font = '11px system-ui, sans-serif'; c.textAlign = 'left';
        c.fillText(fmt(top), bx + 20, by0 + 8); c.fillText('0', bx + 20, by0 + bh);
        c.save(); c.translate(bx - 8, by0 + bh / 2); c.rotate(-Math.PI / 2); c.textAlign = 'center';
        c.fillText(field.label, 0, 0); c.restore();
      }
    }
    function inside(pts, x, y) {
      var hit = false;
      for (var i = 0, j = pts.length - 1; i < pts.length; j = i++) {
        var a = pts[i], b = pts[j];
        if ((a[1] > y) !== (b[1] > y) && x < (b[0] - a[0]) * (y - a[1]) / (b[1] - a[1]) + a[0]) { hit = !hit; }
      }
      return hit;
    }
    var drag = null;
    canvas.addEventListener('mousedown', function (e) { drag = [e.clientX, e.clientY]; });
    window.addEventListener('mouseup', function () { drag = null; });
    canvas.addEventListener('mousemove', function (e) {
      if (drag) {
        state.az -= (e.clientX - drag[0]) * 0.01;
        state.el = Math.max(-1.55, Math.min(1.55, state.el + (e.clientY - drag[1]) * 0.01));
        drag = [e.clientX, e.clientY];
        draw();
        return;
      }
      var r = canvas.getBoundingClientRect(), x = e.clientX - r.left, y = e.clientY - r.top;
      for (var m = markers.length - 1; m >= 0; m--) {
        if (Math.hypot(markers[m].x - x, markers[m].y - y) <= 8) {
          readout.textContent = describe(markers[m].p);
          return;
        }
      }
      for (var i = items.length - 1; i >= 0; i--) {
        if (items[i].pts.length > 2 && inside(items[i].pts, x, y)) {
          var v = field ? field.values[String(items[i].e)] : undefined;
          readout.textContent = 'element ' + items[i].e + (v === undefined ? '' : ' · ' + field.label + ' ' + fmt(v));
          return;
        }
      }
      readout.textContent = '';
    });
    canvas.addEventListener('wheel', function (e) {
      e.preventDefault();
      state.zoom *= e.deltaY < 0 ? 1.1 : 1 / 1.1;
      draw();
    }, { passive: false });
    reset();
    draw();
    root.setAttribute('data-ready', '1');
  }

  // Per posterior, one row per parameter: the credible interval as a bar, the mean as a dot and
  // the update's result as a diamond, all relative to the posterior mean so that parameters of
  // different size share the axis.
  function posteriorViewer(root, data) {
    data.posteriors.forEach(function (po) {
      var level = po.level ? Math.round(po.level * 1000) / 10 + ' %' : 'credible';
      el('h3', { text: po.id + ': ' + level + ' intervals relative to the posterior mean' }, root);
      var rows = po.parameters.length, rowH = 30, f = { l: 150, r: 20, t: 10, b: 44 };
      var canvas = el('canvas', { 'class': 'intervals', 'aria-label': 'credible intervals of ' + po.id }, root);
      var readout = el('div', { 'class': 'readout' }, root);
      var lo = Infinity, hi = -Infinity;
      var rel = po.parameters.map(function (q) {
        var m = q.mean, ok = m !== null && m !== 0;
        var r = function (v) { return ok && v !== null ? v / Math.abs(m) : null; };
        var out = { q: q, lower: r(q.lower), upper: r(q.upper), mean: ok ? m / Math.abs(m) : null, updated: r(q.updated) };
        [out.lower, out.upper, out.mean, out.updated].forEach(function (v) { if (v !== null && isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); } });
        return out;
      });
      if (!isFinite(lo)) { lo = 0; hi = 2; }
      if (hi === lo) { lo -= 0.5; hi += 0.5; }
      var pad = 0.08 * (hi - lo); lo -= pad; hi += pad;
      function draw() {
        var w = Math.max(360, canvas.clientWidth || 800), h = f.t + f.b + rows * rowH, dpr = window.devicePixelRatio || 1;
        canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr); canvas.style.height = h + 'px';
        var c = canvas.getContext('2d');
        c.setTransform(dpr, 0, 0, dpr, 0, 0);
        c.clearRect(0, 0, w, h);
        var pw = w - f.l - f.r;
        var tx = function (v) { return f.l + (v - lo) / (hi - lo) * pw; };
        c.font = '11px system-ui, sans-serif'; c.strokeStyle = '#e3e6eb'; c.fillStyle = '#1d2330'; c.lineWidth = 1;
        linearTicks(lo, hi).forEach(function (t) {
          var px = tx(t);
          c.beginPath(); c.moveTo(px, f.t); c.lineTo(px, h - f.b); c.stroke();
          c.textAlign = 'center'; c.fillText(fmt(t), px, h - f.b + 14);
        });
        c.textAlign = 'center';
        c.fillText('value / |posterior mean|  (bar: interval, dot: mean, diamond: updated)', f.l + pw / 2, h - 8);
        rel.forEach(function (r, i) {
          var y = f.t + (i + 0.5) * rowH;
          c.fillStyle = '#1d2330'; c.textAlign = 'right';
          c.fillText(r.q.name, f.l - 8, y + 4);
          if (r.lower !== null && r.upper !== null) {
            c.fillStyle = 'rgba(31,119,180,0.35)'; c.fillRect(tx(r.lower), y - 7, Math.max(1, tx(r.upper) - tx(r.lower)), 14);
            c.strokeStyle = '#1f77b4'; c.strokeRect(tx(r.lower), y - 7, Math.max(1, tx(r.upper) - tx(r.lower)), 14);
          }
          if (r.mean !== null) { c.fillStyle = '#1f77b4'; c.beginPath(); c.arc(tx(r.mean), y, 4, 0, 2 * Math.PI); c.fill(); }
          if (r.updated !== null) {
            var ux = tx(r.updated);
            c.fillStyle = '#d62728'; c.beginPath(); c.moveTo(ux, y - 6); c.lineTo(ux + 5, y); c.lineTo(ux, y + 6); c.lineTo(ux - 5, y); c.closePath(); c.fill();
          }
        });
      }
      canvas.addEventListener('mousemove', function (e) {
        var r = canvas.getBoundingClientRect(), i = Math.floor((e.clientY - r.top - f.t) / rowH);
        var q = po.parameters[i];
        readout.textContent = q ? q.name + ': mean ' + (q.mean === null ? '—' : fmt(q.mean)) + ', sd ' + (q.sd === null ? '—' : fmt(q.sd)) + ', interval [' + (q.lower === null ? '—' : fmt(q.lower)) + ', ' + (q.upper === null ? '—' : fmt(q.upper)) + ']' : '';
      });
      draw();
    });
    root.setAttribute('data-ready', '1');
  }

  try {
    var data = JSON.parse(document.getElementById('femu-data').textContent);
    var frf = document.getElementById('frf-viewer');
    if (frf) { frfViewer(frf, data); }
    var upd = document.getElementById('update-viewer');
    if (upd) { updateViewer(upd, data); }
    var mesh = document.getElementById('mesh-viewer');
    if (mesh) { meshViewer(mesh, data); }
    var post = document.getElementById('posterior-viewer');
    if (post) { posteriorViewer(post, data); }
    if (!errors.length) { document.body.setAttribute('data-rendered', 'ok'); }
  } catch (e) {
    fail(e && e.stack ? e.stack : e);
  }
})();
