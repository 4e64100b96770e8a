// Stylesheet and script of report.html (inlined into the page; no external resources).
// The script drives the layer viewer and the links between views, chart, regions and
// viewer. `#selftest` in the URL runs a self-test used by the browser test
// (tests/report/report_browser_test.cpp): it moves the slider and records canvas checksums
// in <html data-selftest>.
#include "report/report_internal.hpp"

namespace printtwin::detail {

std::string_view report_css() {
  return R"CSS(
:root{--bg:#f3f5f8;--panel:#fff;--ink:#1d2433;--ink2:#4a5568;--ink3:#7b8696;--line:#e2e7ee;
--ok:#1f8a4c;--ok-bg:#e6f5ec;--bad:#c62828;--bad-bg:#fdecec;--excess:#cb181d;--deficit:#2161ac;
--accent:#2f5cd0;--mono:ui-monospace,SFMono-Regular,Menlo,Consolas,"Liberation Mono",monospace}
*{box-sizing:border-box}
html{-webkit-text-size-adjust:100%}
body{margin:0;background:var(--bg);color:var(--ink);font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,
"Helvetica Neue",Arial,"Noto Sans",sans-serif;font-variant-numeric:tabular-nums}
.wrap{max-width:1320px;margin:0 auto;padding:0 20px}
header.top{background:#161b26;color:#e8ecf3}
header.top .wrap{display:flex;align-items:center;justify-content:space-between;gap:16px;min-height:48px;flex-wrap:wrap}
.brand{font-weight:650;letter-spacing:.2px;display:flex;align-items:center;gap:8px;font-size:15px}
.brand span{font-weight:400;color:#9aa6b8}
.logo{width:20px;height:20px;fill:#3b6fe0;stroke:#b9cdf7;stroke-width:1.2;stroke-linejoin:round}
.top-meta{display:flex;gap:14px;flex-wrap:wrap;color:#aab4c4;font-size:12.5px}
.top-meta span:first-child{color:#fff;font-weight:600}
main{padding-top:20px;padding-bottom:8px}
h1{font-size:22px;margin:0 0 4px;letter-spacing:-.2px}
h2{font-size:16px;margin:0;letter-spacing:-.1px}
h3{font-size:13px;margin:14px 0 6px;color:var(--ink2);font-weight:600}
h2 small,h3 small{font-weight:400;color:var(--ink3);font-size:12px;margin-left:6px}
.panel,.verdict,.card{background:var(--panel);border:1px solid var(--line);border-radius:10px;
box-shadow:0 1px 2px rgba(16,24,40,.04)}
.panel{padding:16px 18px;margin-bottom:16px;min-width:0}
.panel-head{display:flex;flex-direction:column;gap:2px;margin-bottom:10px}
.panel-head p{margin:0;color:var(--ink3);font-size:12.5px;max-width:900px}
.verdict{display:grid;grid-template-columns:auto 1fr minmax(320px,440px);gap:20px;align-items:center;
padding:18px 20px;margin-bottom:16px;border-left:6px solid var(--ok)}
.verdict.is-fail{border-left-color:var(--bad)}
.badge{font-size:26px;font-weight:800;letter-spacing:1px;padding:10px 18px;border-radius:8px;
color:var(--ok);background:var(--ok-bg)}
.is-fail .badge{color:var(--bad);background:var(--bad-bg)}
.verdict-text p{margin:0;color:var(--ink2)}
table{border-collapse:collapse;width:100%}
th{text-align:left;font-weight:600;color:var(--ink2)}
td,th{padding:5px 8px;vertical-align:top}
.num{text-align:right;white-space:nowrap}
.mono{font-family:var(--mono);font-size:12.5px}
.hash{word-break:break-all;font-size:12px}
.gates{font-size:13px}
.gates th{font-size:11.5px;text-transform:uppercase;letter-spacing:.4px;color:var(--ink3);border-bottom:1px solid var(--line)}
.gates td{border-bottom:1px solid #f0f2f6;white-space:nowrap}
.gates tr.bad td:first-child{color:var(--bad);font-weight:600}
.gate-bar{display:inline-block;position:relative;width:70px;height:6px;border-radius:3px;background:#edf0f4;
margin-right:8px;vertical-align:middle;overflow:hidden}
.gate-bar span{position:absolute;left:0;top:0;bottom:0;background:var(--ok);border-radius:3px}
.gate-bar i{position:absolute;left:66.6%;top:-2px;bottom:-2px;width:1.5px;background:#8a94a6}
tr.bad .gate-bar span{background:var(--bad)}
.chip{display:inline-block;font-size:11px;font-weight:650;text-transform:uppercase;letter-spacing:.4px;
padding:1px 7px;border-radius:10px;white-space:nowrap}
.chip-ok{color:var(--ok);background:var(--ok-bg)}
.chip-bad,.chip-error{color:var(--bad);background:var(--bad-bg)}
.chip-warning{color:#9a5b00;background:#fff3dc}
.chip-info{color:#4a5568;background:#edf0f4}
.chip-missing{color:var(--deficit);background:#e5eefa}
.chip-excess{color:var(--excess);background:#fdeaea}
.cards{display:grid;grid-template-columns:repeat(auto-fit,minmax(190px,1fr));gap:12px;margin-bottom:16px}
.card{padding:12px 14px;border-top:3px solid #d5dbe4}
.card.warn-excess{border-top-color:var(--excess)}
.card.warn-deficit{border-top-color:var(--deficit)}
.card-label{font-size:11.5px;text-transform:uppercase;letter-spacing:.5px;color:var(--ink3);font-weight:600}
.card-value{font-size:26px;font-weight:650;letter-spacing:-.5px;margin:2px 0}
.card-value .unit{font-size:14px;font-weight:500;color:var(--ink3);margin-left:3px;letter-spacing:0}
.card-sub{font-size:12px;color:var(--ink3)}
.legend{max-width:640px;margin:4px 0 14px}
.legend-bar{height:12px;border-radius:3px;border:1px solid rgba(0,0,0,.08)}
.legend-ticks{position:relative;height:18px;font-size:11.5px;color:var(--ink2)}
.legend-ticks span{position:absolute;top:2px;transform:translateX(-50%);white-space:nowrap}
.legend-ticks span:first-child{transform:none}
.legend-ticks span:last-child{transform:translateX(-100%)}
.legend-names{display:flex;justify-content:space-between;font-size:11.5px;color:var(--ink3)}
.views{display:grid;grid-template-columns:repeat(4,minmax(0,1fr));gap:12px}
.view{margin:0;background:linear-gradient(#fbfcfd,#f2f4f7);border:1px solid var(--line);border-radius:8px;
padding:8px;display:flex;flex-direction:column;align-items:center;justify-content:center;min-width:0}
.view-main{grid-column:1/3;grid-row:1/3}
.view-img{position:relative;width:100%;max-width:100%}
.view-img img{display:block;width:100%;height:auto;image-rendering:auto}
.view figcaption{font-size:12px;color:var(--ink3);margin-top:4px}
svg.pins{position:absolute;inset:0;width:100%;height:100%;overflow:visible}
.pin{cursor:pointer}
.pin rect{fill:none;stroke-width:1.5;stroke-dasharray:4 3}
.pin circle{stroke:#fff;stroke-width:2}
.pin text{fill:#fff;font-size:11px;font-weight:700;text-anchor:middle;pointer-events:none}
.view-main .pin text{font-size:12.5px}
.pin-missing rect{stroke:var(--deficit)}.pin-missing circle{fill:var(--deficit)}
.pin-excess rect{stroke:var(--excess)}.pin-excess circle{fill:var(--excess)}
.pin-hidden{opacity:.45}
.pin.flash circle{stroke:#ffd43b;stroke-width:3.5}
.two{display:grid;grid-template-columns:minmax(0,1fr) minmax(0,1.25fr);gap:16px}
.two>.panel{margin-bottom:16px}
svg.chart{width:100%;height:auto;display:block;font-size:11px}
.chart .grid{stroke:#edf0f4;stroke-width:1}
.chart .axis{stroke:#98a2b3;stroke-width:1}
.chart .tolband{fill:#e6f5ec}
.chart .ylab{text-anchor:end;fill:var(--ink3)}
.chart .xlab{text-anchor:middle;fill:var(--ink3)}
.chart .xunit{text-anchor:end;fill:var(--ink3)}
.chart .yunit{text-anchor:end;fill:var(--ink3)}
.chart .note{fill:var(--ink3);font-size:10.5px}
.chart .envelope{fill:rgba(120,130,150,.12)}
.chart polyline{fill:none;stroke-width:1.6;stroke-linejoin:round}
.chart .line-excess{stroke:var(--excess)}
.chart .line-deficit{stroke:var(--deficit)}
.chart .line-rms{stroke:#3c4454;stroke-dasharray:3 2;stroke-width:1.2}
.chart .cols rect{fill:transparent;cursor:pointer}
.chart .cols rect:hover{fill:rgba(47,92,208,.08)}
#layer-cursor{stroke:var(--accent);stroke-width:1.5}
.chart-key{display:flex;gap:16px;flex-wrap:wrap;font-size:12px;color:var(--ink2);margin:6px 0 12px}
.chart-key span::before{content:"";display:inline-block;width:16px;height:3px;margin-right:6px;vertical-align:middle}
.k-excess::before{background:var(--excess)}.k-deficit::before{background:var(--deficit)}
.k-rms::before{background:repeating-linear-gradient(90deg,#3c4454 0 3px,transparent 3px 5px)}
.k-tol::before{background:#cfeedd;height:10px!important}
.stats{font-size:12px}
.stats th,.stats td{border-bottom:1px solid #f0f2f6;white-space:nowrap;text-align:right;padding:4px 5px}
.stats th:first-child{text-align:left}
.stats thead th{font-size:11.5px;color:var(--ink3)}
.fine{font-size:12px;color:var(--ink3);margin:6px 0 0}
.viewer{display:grid;grid-template-columns:minmax(0,1fr) 260px;gap:16px;align-items:start}
.viewer-stage{position:relative;background:#fafbfc;border:1px solid var(--line);border-radius:8px;overflow:hidden}
#layer-canvas{display:block;width:100%;height:auto;aspect-ratio:16/10;cursor:crosshair}
.tip{position:absolute;pointer-events:none;background:rgba(22,27,38,.92);color:#fff;font-size:12px;
padding:4px 7px;border-radius:5px;white-space:nowrap;transform:translate(10px,-120%)}
.viewer-title{font-size:18px;font-weight:650;margin-bottom:8px}
.viewer-controls{display:flex;gap:6px;align-items:center}
.viewer-controls input{flex:1;accent-color:var(--accent)}
.viewer-controls button{width:30px;height:30px;border:1px solid var(--line);background:#fff;border-radius:6px;
font-size:18px;line-height:1;cursor:pointer;color:var(--ink2)}
.viewer-controls button:hover{background:#f3f5f8}
.layer-stats{display:grid;grid-template-columns:auto 1fr;gap:3px 12px;margin:14px 0;font-size:13px}
.layer-stats dt{color:var(--ink3)}
.layer-stats dd{margin:0;text-align:right;font-weight:600}
button.link{background:none;border:0;color:var(--accent);padding:0;font:inherit;cursor:pointer;font-size:13px}
button.link:hover{text-decoration:underline}
.viewer-key{display:flex;flex-direction:column;gap:5px;margin-top:16px;font-size:12px;color:var(--ink2)}
.viewer-key span::before{content:"";display:inline-block;width:14px;height:10px;margin-right:8px;vertical-align:middle}
.k-outline::before{border-top:2px solid #4b5563;height:0!important}
.k-dots::before{background:radial-gradient(circle,#41ab5d 2px,transparent 2.5px) 0 0/5px 5px}
.k-ring::before{border:2px solid var(--deficit);border-radius:50%;width:10px!important}
.k-box::before{border:1.5px dashed var(--excess)}
.scroll{overflow-x:auto}
.list{font-size:13px}
.list thead th{font-size:11.5px;text-transform:uppercase;letter-spacing:.4px;color:var(--ink3);
border-bottom:1px solid var(--line);white-space:nowrap}
.list td{border-bottom:1px solid #f0f2f6}
#regions tbody tr{cursor:pointer}
#regions tbody tr:hover,#regions tbody tr.active{background:#f5f8ff}
.rnum{display:inline-block;min-width:20px;height:20px;line-height:20px;text-align:center;border-radius:10px;
color:#fff;font-size:11px;font-weight:700;padding:0 5px}
.rnum-missing{background:var(--deficit)}.rnum-excess{background:var(--excess)}
.empty{color:var(--ink3);margin:4px 0}
.kv-grid{display:grid;grid-template-columns:repeat(auto-fit,minmax(300px,1fr));gap:0 24px}
.kv{font-size:13px}
.kv th{width:42%;font-weight:500;color:var(--ink3)}
.kv td,.kv th{border-bottom:1px solid #f0f2f6}
footer{color:var(--ink3);font-size:12px;padding:6px 20px 28px}
@media (max-width:1000px){.verdict{grid-template-columns:auto 1fr}.gates{grid-column:1/-1}
.two{grid-template-columns:1fr}.views{grid-template-columns:repeat(2,minmax(0,1fr))}
.view-main{grid-column:1/-1;grid-row:auto}.viewer{grid-template-columns:1fr}}
@media (max-width:560px){.views{grid-template-columns:1fr}.verdict{grid-template-columns:1fr}}
@media print{body{background:#fff}.panel,.verdict,.card{box-shadow:none}header.top{background:#fff;color:#000}}
)CSS";
}

std::string_view report_js() {
  return R"JS(
(function () {
  "use strict";
  var root = document.documentElement;
  var errors = 0;
  window.addEventListener("error", function () { errors += 1; root.setAttribute("data-js-errors", String(errors)); });

  function b64bytes(s) {
    var bin = atob(s || ""), out = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out;
  }
  function u16(bytes) { return new Uint16Array(bytes.buffer, 0, bytes.length >> 1); }
  function i8(bytes) { return new Int8Array(bytes.buffer, 0, bytes.length); }
  function fmt(v, d) { var s = v.toFixed(d); return (v > 0 && Number(s) !== 0 ? "+" : "") + s.replace("-", "\u2212"); }

  var data = JSON.parse(document.getElementById("viewer-data").textContent);
  var layers = data.layers || [];
  var canvas = document.getElementById("layer-canvas");
  // The self-test reads the canvas back; tell the browser up front.
  var ctx = canvas.getContext("2d", location.hash === "#selftest" ? { willReadFrequently: true } : {});
  var slider = document.getElementById("layer-slider");
  var title = document.getElementById("layer-title");
  var statsBox = document.getElementById("layer-stats");
  var tip = document.getElementById("layer-tip");
  var cursor = document.getElementById("layer-cursor");
  var chart = document.getElementById("layer-chart");
  var lut = b64bytes(data.lut || "");
  var decoded = {};
  var current = 0, highlight = -1, view = null;

  function decode(k) {
    if (decoded[k]) return decoded[k];
    var L = layers[k];
    var c = u16(b64bytes(L.c)), loops = [], p = 1;
    for (var n = c.length ? c[0] : 0; n > 0; n--) {
      var m = c[p++], arr = new Float32Array(2 * m);
      for (var i = 0; i < m; i++) { arr[2 * i] = data.x0 + c[p++] * data.q; arr[2 * i + 1] = data.y0 + c[p++] * data.q; }
      loops.push(arr);
    }
    function points(xyKey, dKey) {
      var xy = u16(b64bytes(L[xyKey])), d = i8(b64bytes(L[dKey])), n = d.length, out = { x: new Float32Array(n), y: new Float32Array(n), d: d };
      for (var i = 0; i < n; i++) { out.x[i] = data.x0 + xy[2 * i] * data.q; out.y[i] = data.y0 + xy[2 * i + 1] * data.q; }
      return out;
    }
    decoded[k] = { loops: loops, dep: points("p", "pd"), mesh: points("m", "md") };
    return decoded[k];
  }

  function color(q) {
    var i = Math.max(0, Math.min(255, Math.round((q / 127 + 1) * 127.5))) * 3;
    return "rgb(" + lut[i] + "," + lut[i + 1] + "," + lut[i + 2] + ")";
  }

  function resize() {
    var r = canvas.getBoundingClientRect(), dpr = window.devicePixelRatio || 1;
    var w = Math.max(320, Math.round(r.width * dpr)), h = Math.round(w * 10 / 16);
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
  }

  function draw() {
    if (!layers.length) return;
    resize();
    var W = canvas.width, H = canvas.height;
    var dpr = W / Math.max(1, canvas.getBoundingClientRect().width || W);
    var e = data.ext, pad = 28 * dpr;
    var s = Math.min((W - 2 * pad) / Math.max(e[2] - e[0], 1e-3), (H - 2 * pad) / Math.max(e[3] - e[1], 1e-3));
    var ox = (W - (e[2] - e[0]) * s) / 2 - e[0] * s, oy = (H + (e[3] - e[1]) * s) / 2 + e[1] * s;
    view = { s: s, ox: ox, oy: oy, dpr: dpr };
    function X(x) { return ox + x * s; }
    function Y(y) { return oy - y * s; }
    ctx.fillStyle = "#fafbfc"; ctx.fillRect(0, 0, W, H);
    // 1/5/10 mm grid depending on zoom.
    var step = [1, 2, 5, 10, 20, 50, 100].find(function (g) { return g * s >= 28 * dpr; }) || 100;
    ctx.strokeStyle = "#eceff3"; ctx.lineWidth = 1;
    ctx.beginPath();
    for (var gx = Math.floor(e[0] / step) * step; gx <= e[2] + step; gx += step) { ctx.moveTo(X(gx), 0); ctx.lineTo(X(gx), H); }
    for (var gy = Math.floor(e[1] / step) * step; gy <= e[3] + step; gy += step) { ctx.moveTo(0, Y(gy)); ctx.lineTo(W, Y(gy)); }
    ctx.stroke();
    var L = layers[current], D = decode(current);
    // Mesh cross-section: light fill (even-odd), then outline.
    ctx.beginPath();
    D.loops.forEach(function (pts) {
      for (var i = 0; i < pts.length; i += 2) { if (i === 0) ctx.moveTo(X(pts[0]), Y(pts[1])); else ctx.lineTo(X(pts[i]), Y(pts[i + 1])); }
    });
    ctx.fillStyle = "#e8ecf2"; ctx.fill("evenodd");
    ctx.strokeStyle = "#4b5563"; ctx.lineWidth = 1.4 * dpr; ctx.lineJoin = "round"; ctx.stroke();
    // Deposit surface points.
    var sz = Math.max(2 * dpr, (data.voxel || 0.05) * s * 1.1), half = sz / 2;
    for (var i = 0; i < D.dep.d.length; i++) { ctx.fillStyle = color(D.dep.d[i]); ctx.fillRect(X(D.dep.x[i]) - half, Y(D.dep.y[i]) - half, sz, sz); }
    // Out-of-tolerance mesh points: rings.
    ctx.lineWidth = 1.6 * dpr;
    for (var j = 0; j < D.mesh.d.length; j++) {
      ctx.beginPath(); ctx.arc(X(D.mesh.x[j]), Y(D.mesh.y[j]), 3.2 * dpr, 0, 2 * Math.PI);
      ctx.strokeStyle = color(D.mesh.d[j]); ctx.stroke();
    }
    // Regions active on this layer.
    // Region boxes: the selected region, else the largest few that cross this layer.
    (data.regions || []).forEach(function (r, idx) {
      if (L.l < r.l0 || L.l > r.l1) return;
      if (highlight >= 0 ? idx !== highlight : idx >= 8) return;
      var x0 = X(r.b[0]) - 4 * dpr, y0 = Y(r.b[3]) - 4 * dpr, x1 = X(r.b[2]) + 4 * dpr, y1 = Y(r.b[1]) + 4 * dpr;
      var col = r.k === "missing" ? "#2161ac" : "#cb181d";
      ctx.setLineDash([5 * dpr, 4 * dpr]); ctx.strokeStyle = col; ctx.lineWidth = (idx === highlight ? 2.6 : 1.5) * dpr;
      ctx.strokeRect(x0, y0, x1 - x0, y1 - y0); ctx.setLineDash([]);
      ctx.fillStyle = col; ctx.beginPath(); ctx.arc(x0, y0, 9 * dpr, 0, 2 * Math.PI); ctx.fill();
      ctx.fillStyle = "#fff"; ctx.font = "bold " + Math.round(11 * dpr) + "px system-ui,sans-serif";
      ctx.textAlign = "center"; ctx.textBaseline = "middle"; ctx.fillText(String(idx + 1), x0, y0 + 0.5);
    });
    // Scale bar.
    var bar = step * s;
    ctx.fillStyle = "#4b5563"; ctx.fillRect(14 * dpr, H - 16 * dpr, bar, 2 * dpr);
    ctx.font = Math.round(11 * dpr) + "px system-ui,sans-serif"; ctx.textAlign = "left"; ctx.textBaseline = "bottom";
    ctx.fillText(step + " mm", 14 * dpr, H - 20 * dpr);
    ctx.textAlign = "right"; ctx.fillText("x \u2192  y \u2191", W - 12 * dpr, H - 10 * dpr);
  }

  function updateText() {
    var L = layers[current];
    title.textContent = "Layer " + L.l + " \u00b7 z " + L.z.toFixed(2) + " mm";
    var rows = [["excess (max)", fmt(L.s[0], 3) + " mm"], ["deficit (max)", fmt(L.s[1], 3) + " mm"],
      ["RMS", L.s[2].toFixed(3) + " mm"], ["within tolerance", L.s[3].toFixed(1) + " %"], ["deposit points", String(L.np)],
      ["shown", (current + 1) + " of " + layers.length + (data.total_layers > layers.length ? " (of " + data.total_layers + ")" : "")]];
    statsBox.innerHTML = "";
    rows.forEach(function (r) {
      var dt = document.createElement("dt"), dd = document.createElement("dd");
      dt.textContent = r[0]; dd.textContent = r[1]; statsBox.appendChild(dt); statsBox.appendChild(dd);
    });
    if (cursor && chart) {
      var col = chart.querySelector('.cols rect[data-layer="' + L.l + '"]');
      if (col) { var x = Number(col.getAttribute("x")) + Number(col.getAttribute("width")) / 2; cursor.setAttribute("x1", x); cursor.setAttribute("x2", x); }
    }
  }

  function setLayer(k) {
    if (!layers.length) return;
    current = Math.max(0, Math.min(layers.length - 1, k | 0));
    slider.value = String(current);
    updateText();
    draw();
  }
  function indexOfLayer(layer) {
    var best = 0;
    for (var i = 0; i < layers.length; i++) if (Math.abs(layers[i].l - layer) < Math.abs(layers[best].l - layer)) best = i;
    return best;
  }

  if (layers.length) {
    slider.max = String(layers.length - 1);
    slider.addEventListener("input", function () { setLayer(Number(slider.value)); });
    document.getElementById("layer-prev").addEventListener("click", function () { setLayer(current - 1); });
    document.getElementById("layer-next").addEventListener("click", function () { setLayer(current + 1); });
    slider.addEventListener("keydown", function (ev) { if (ev.key === "PageUp") setLayer(current + 10); if (ev.key === "PageDown") setLayer(current - 10); });
    document.getElementById("layer-worst").addEventListener("click", function () {
      var w = 0, wv = -1;
      layers.forEach(function (L, i) { var v = Math.max(L.s[0], -L.s[1]); if (v > wv) { wv = v; w = i; } });
      setLayer(w);
    });
    if (chart) chart.addEventListener("click", function (ev) {
      var t = ev.target;
      if (t && t.getAttribute && t.getAttribute("data-layer") !== null) {
        setLayer(indexOfLayer(Number(t.getAttribute("data-layer"))));
        document.getElementById("layers").scrollIntoView({ behavior: "smooth", block: "nearest" });
      }
    });
    canvas.addEventListener("mousemove", function (ev) {
      if (!view) return;
      var r = canvas.getBoundingClientRect(), px = (ev.clientX - r.left) * view.dpr, py = (ev.clientY - r.top) * view.dpr;
      var D = decode(current), best = -1, bd = (8 * view.dpr) * (8 * view.dpr), src = null;
      [D.dep, D.mesh].forEach(function (P) {
        for (var i = 0; i < P.d.length; i++) {
          var dx = view.ox + P.x[i] * view.s - px, dy = view.oy - P.y[i] * view.s - py, d2 = dx * dx + dy * dy;
          if (d2 < bd) { bd = d2; best = i; src = P; }
        }
      });
      if (best < 0) { tip.hidden = true; return; }
      tip.hidden = false;
      tip.style.left = (ev.clientX - r.left) + "px"; tip.style.top = (ev.clientY - r.top) + "px";
      tip.textContent = (src === D.dep ? "deposit" : "mesh") + " (" + src.x[best].toFixed(2) + ", " + src.y[best].toFixed(2) + ") d = " +
        fmt(src.d[best] / 127 * data.range, 3) + " mm";
    });
    canvas.addEventListener("mouseleave", function () { tip.hidden = true; });
    window.addEventListener("resize", draw);
  } else {
    title.textContent = "No layer data";
  }

  function showRegion(n) {
    var r = (data.regions || [])[n - 1];
    highlight = n - 1;
    document.querySelectorAll("#regions tbody tr").forEach(function (tr) { tr.classList.toggle("active", tr.getAttribute("data-region") === String(n)); });
    document.querySelectorAll(".pin").forEach(function (g) { g.classList.toggle("flash", g.getAttribute("data-region") === String(n)); });
    if (r && layers.length) setLayer(indexOfLayer(r.l0));
  }
  document.querySelectorAll("#regions tbody tr").forEach(function (tr) {
    tr.addEventListener("click", function () {
      showRegion(Number(tr.getAttribute("data-region")));
      document.getElementById("layers").scrollIntoView({ behavior: "smooth", block: "nearest" });
    });
  });
  document.querySelectorAll(".pin").forEach(function (g) {
    g.addEventListener("click", function () {
      var n = Number(g.getAttribute("data-region"));
      showRegion(n);
      var row = document.querySelector('#regions tbody tr[data-region="' + n + '"]');
      if (row) row.scrollIntoView({ behavior: "smooth", block: "center" });
    });
  });

  // Start on the worst layer when there is one, else the first.
  if (layers.length) {
    var start = 0, sv = -1;
    layers.forEach(function (L, i) { var v = Math.max(L.s[0], -L.s[1]); if (v > sv) { sv = v; start = i; } });
    setLayer(start);
  }

  // FNV-1a over the canvas pixels, and the number of pixels that differ from the background.
  function checksum() {
    var px = ctx.getImageData(0, 0, canvas.width, canvas.height).data, h = 2166136261, drawn = 0;
    for (var i = 0; i < px.length; i += 4) {
      h ^= px[i]; h = Math.imul(h, 16777619) >>> 0;
      h ^= px[i + 2]; h = Math.imul(h, 16777619) >>> 0;
      if (Math.abs(px[i] - 250) + Math.abs(px[i + 1] - 251) + Math.abs(px[i + 2] - 252) > 60) drawn++;
    }
    return { h: h >>> 0, drawn: drawn };
  }
  if (location.hash === "#selftest") {
    var result = "no-layers";
    if (layers.length > 1) {
      var a = 0, b = layers.length >> 1;
      slider.value = String(a); slider.dispatchEvent(new Event("input"));
      var ca = checksum();
      slider.value = String(b); slider.dispatchEvent(new Event("input"));
      var cb = checksum();
      result = (ca.h !== cb.h && current === b ? "ok" : "same") + " " + ca.h + " " + cb.h + " layers=" + layers.length +
        " drawn=" + Math.min(ca.drawn, cb.drawn);
    }
    root.setAttribute("data-selftest", result);
  }
  root.setAttribute("data-ready", "1");
})();
)JS";
}

}  // namespace printtwin::detail
