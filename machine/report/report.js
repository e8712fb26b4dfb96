// vcnc report page: unpacks the data block, draws the linked views, exposes window.vcncReport.
// window.vcncReport.select(t, run) / selectDistance(s) pick an instant in every view and return
// what the pick panel shows (line number, text, position, ...), so tests can drive the page.
"use strict";
(function () {
  const AXES = ["X", "Y", "Z"];
  const AXIS_COLOURS = ["#d62728", "#2ca02c", "#1f77b4"];
  const RUN_COLOURS = ["#1f77b4", "#ff7f0e"];
  const TYPED = { float32: Float32Array, float64: Float64Array, int32: Int32Array, uint8: Uint8Array };
  const info = JSON.parse(document.getElementById("vcnc-info").textContent);
  let A = null;
  const views = { time: [], dist: null, path: null, toolTrace: [] };

  function el(tag, attrs, text) {
    const e = document.createElement(tag);
    Object.assign(e, attrs || {});
    if (text !== undefined) e.textContent = text;
    return e;
  }

  async function unpack() {
    const b64 = document.getElementById("vcnc-blob").textContent;
    const raw = atob(b64);
    const bin = new Uint8Array(raw.length);
    for (let i = 0; i < raw.length; i++) bin[i] = raw.charCodeAt(i);
    const stream = new Blob([bin]).stream().pipeThrough(new DecompressionStream("gzip"));
    const buf = await new Response(stream).arrayBuffer();
    const out = {};
    for (const [name, [dtype, offset, n]] of Object.entries(info.arrays)) {
      out[name] = new TYPED[dtype](buf, offset, n);
    }
    return out;
  }

  // the last index i with arr[i] <= v (0 if none)
  function floorIndex(arr, v) {
    let lo = 0, hi = arr.length - 1;
    if (hi < 0 || v < arr[0]) return 0;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if (arr[mid] <= v) lo = mid; else hi = mid - 1;
    }
    return lo;
  }

  function run(k) {
    const r = info.runs[k];
    if (!r._text) {
      const bytes = A[`r${k}_text`];
      r._text = new TextDecoder().decode(bytes).split("\n");
      r._total_s = r.periods * r.period_s;
      const s = A[`r${k}_path_s`];
      r._length_mm = s.length ? s[s.length - 1] : 0;
    }
    return r;
  }

  function lineText(k, line) {
    const nums = A[`r${k}_text_line`];
    const i = floorIndex(nums, line);
    return nums.length && nums[i] === line ? run(k)._text[i] : "";
  }

  // position, distance and row at a period, between the path points around it
  function pathAt(k, period) {
    const pp = A[`r${k}_path_period`], xyz = A[`r${k}_path_xyz`], s = A[`r${k}_path_s`];
    const i = floorIndex(pp, period);
    const j = Math.min(i + 1, pp.length - 1);
    const f = pp[j] > pp[i] ? Math.min(1, Math.max(0, (period - pp[i]) / (pp[j] - pp[i]))) : 0;
    const lerp = (a, b) => a + f * (b - a);
    return {
      pos: [0, 1, 2].map((c) => lerp(xyz[3 * i + c], xyz[3 * j + c])),
      s: lerp(s[i], s[j]),
      feed: A[`r${k}_path_feed`][j],
    };
  }

  function periodAtDistance(k, dist) {
    const s = A[`r${k}_path_s`], pp = A[`r${k}_path_period`];
    const i = floorIndex(s, dist);
    const j = Math.min(i + 1, s.length - 1);
    const f = s[j] > s[i] ? Math.min(1, Math.max(0, (dist - s[i]) / (s[j] - s[i]))) : 0;
    return Math.round(pp[i] + f * (pp[j] - pp[i]));
  }

  function describe(k, t) {
    const r = run(k);
    const period = Math.max(0, Math.min(r.periods - 1, Math.round(t / r.period_s) - 1));
    const runs = A[`r${k}_run_first`];
    const line = A[`r${k}_run_line`][floorIndex(runs, period)];
    const where = pathAt(k, period);
    const bucket = Math.floor(period / r.width);
    const lo = A[`r${k}_env_lo`][bucket * r.signals.length], hi = A[`r${k}_env_hi`][bucket * r.signals.length];
    const reason = info.limit_names[A[`r${k}_env_reason`][bucket]];
    return {
      run: k, t: (period + 1) * r.period_s, period, line, text: lineText(k, line), s: where.s, pos: where.pos,
      feed_mm_s: r.width === 1 ? lo : [lo, hi], reason,
    };
  }

  function fmt(d) {
    const feed = Array.isArray(d.feed_mm_s) ? `${d.feed_mm_s[0].toFixed(2)}…${d.feed_mm_s[1].toFixed(2)}`
      : d.feed_mm_s.toFixed(2);
    const name = info.runs.length > 1 ? `${info.runs[d.run].name}: ` : "";
    return `${name}line ${d.line}: ${d.text}\n  t ${d.t.toFixed(3)} s · s ${d.s.toFixed(3)} mm · ` +
      `X${d.pos[0].toFixed(3)} Y${d.pos[1].toFixed(3)} Z${d.pos[2].toFixed(3)} · feed ${feed} mm/s · ` +
      `limited by ${d.reason}`;
  }

  function cursor(x, colour) {
    return { type: "line", xref: "x", yref: "paper", x0: x, x1: x, y0: 0, y1: 1,
      line: { color: colour || "#000", width: 1.5, dash: "dot" } };
  }

  function show(picks) {
    document.getElementById("pick").textContent = picks.map(fmt).join("\n");
    picks.forEach((d) => {
      const tv = views.time[d.run];
      if (tv) Plotly.relayout(tv, { shapes: [cursor(d.t)] });
      if (views.path) {
        Plotly.restyle(views.path, { x: [[d.pos[0]]], y: [[d.pos[1]]], z: [[d.pos[2]]] }, [views.toolTrace[d.run]]);
      }
    });
    if (views.dist) {
      Plotly.relayout(views.dist, { shapes: picks.map((d) => cursor(d.run === 0 ? d.s : d.s / ratio(),
        RUN_COLOURS[d.run])) });
    }
    const slider = document.getElementById("tslider");
    if (slider && picks[0].run === 0) slider.value = picks[0].t;
  }

  // run b's distance per millimetre of run a's, for aligning the two by distance
  function ratio() {
    return info.runs.length > 1 && run(0)._length_mm > 0 ? run(1)._length_mm / run(0)._length_mm : 1;
  }

  function select(t, k) {
    const d = describe(k || 0, t);
    show([d]);
    return d;
  }

  function selectDistance(s) {
    const picks = info.runs.map((r, k) => {
      const dist = k === 0 ? s : s * ratio();
      return describe(k, (periodAtDistance(k, dist) + 1) * run(k).period_s);
    });
    show(picks);
    return picks;
  }

  // M4 line through each bucket's minimum and maximum, in time order: no extreme is lost
  function envelopeXY(prefix, m, j, xOf) {
    const lo = A[`${prefix}lo`], hi = A[`${prefix}hi`], alo = A[`${prefix}arg_lo`], ahi = A[`${prefix}arg_hi`];
    const nb = lo.length / m;
    const x = new Float64Array(2 * nb), y = new Float32Array(2 * nb);
    for (let b = 0; b < nb; b++) {
      const q = b * m + j;
      let p1 = alo[q], v1 = lo[q], p2 = ahi[q], v2 = hi[q];
      if (p1 > p2) { [p1, p2] = [p2, p1]; [v1, v2] = [v2, v1]; }
      x[2 * b] = p1 < 0 ? NaN : xOf(p1); y[2 * b] = p1 < 0 ? NaN : v1;
      x[2 * b + 1] = p2 < 0 ? NaN : xOf(p2); y[2 * b + 1] = p2 < 0 ? NaN : v2;
    }
    return { x, y };
  }

  // shaded bands, one trace per limiting reason: the reason holding most periods of each bucket
  function reasonBands(k, prefix, xs, top, yaxis, xaxis) {
    const reason = A[`${prefix}reason`];
    return info.limit_names.map((name, code) => {
      const y = new Float32Array(xs.length);
      let any = false;
      for (let b = 0; b < xs.length; b++) {
        const c = reason[Math.min(b, reason.length - 1)] === code;
        y[b] = c ? top : 0;
        any = any || c;
      }
      return any ? { type: "scatter", mode: "lines", x: xs, y, line: { width: 0, shape: "hv" }, fill: "tozeroy",
        fillcolor: info.limit_colours[code] + "55", name: `limit: ${name}`, hoverinfo: "skip", xaxis, yaxis,
        legendgroup: name } : null;
    }).filter(Boolean);
  }

  function dataRange(ys, limit) {
    let lo = Infinity, hi = -Infinity;
    for (const y of ys) for (let i = 0; i < y.length; i++) if (y[i] === y[i]) { lo = Math.min(lo, y[i]); hi = Math.max(hi, y[i]); }
    if (!(hi >= lo)) { lo = -1; hi = 1; }
    const span = Math.max(hi - lo, 1e-9);
    // the limit joins the range when it is near the data; far above, a flat line would hide the data
    if (limit && limit <= hi + 1.5 * span) hi = Math.max(hi, limit);
    if (limit && -limit >= lo - 1.5 * span) lo = Math.min(lo, -limit);
    return [lo - 0.05 * span, hi + 0.05 * span];
  }

  function timeFigure(k, div) {
    const r = run(k), T = r.period_s, W = r.width;
    const tOf = (p) => (p + 1) * T;
    const nb = A[`r${k}_env_reason`].length;
    const xs = new Float64Array(nb + 1);
    for (let b = 0; b <= nb; b++) xs[b] = Math.min(b * W, r.periods) * T;
    const feed = envelopeXY(`r${k}_env_`, r.signals.length, 0, tOf);
    let top = 0;
    for (let i = 0; i < feed.y.length; i++) if (feed.y[i] > top) top = feed.y[i];
    top = top * 1.08 || 1;
    const traces = reasonBands(k, `r${k}_env_`, xs, top, "y", "x");
    traces.push({ type: "scattergl", mode: "lines", x: feed.x, y: feed.y, name: "planned feed", line: { color: "#000", width: 1 },
      yaxis: "y", xaxis: "x" });
    const rows = [["feed mm/s", null, null]];
    const layout = { height: 820, margin: { l: 70, r: 20, t: 30, b: 40 }, hovermode: "closest",
      legend: { orientation: "h", y: 1.04 }, xaxis: { title: { text: "t s" }, anchor: "y4" } };
    const kinds = [["v", 1, "velocity mm/s"], ["a", 4, `accel mm/s² (${r.stencil_periods}-period stencil)`],
      ["j", 7, "jerk mm/s³"]];
    kinds.forEach(([kind, j0, label], row) => {
      const yaxis = `y${row + 2}`;
      const ys = [];
      AXES.forEach((ax, a) => {
        const e = envelopeXY(`r${k}_env_`, r.signals.length, j0 + a, tOf);
        ys.push(e.y);
        const lim = r.limits[kind] ? r.limits[kind][a] : null;
        traces.push({ type: "scattergl", mode: "lines", x: e.x, y: e.y, name: `${ax} ${kind}`, yaxis, xaxis: "x",
          line: { color: AXIS_COLOURS[a], width: 1 }, legendgroup: ax });
        if (lim) {
          traces.push({ type: "scatter", mode: "lines", x: [0, r._total_s, null, 0, r._total_s], y: [lim, lim, null, -lim, -lim],
            name: `${ax} ${kind} limit ±${lim}`, yaxis, xaxis: "x", hoverinfo: "name",
            line: { color: AXIS_COLOURS[a], width: 1, dash: "dash" }, legendgroup: ax, showlegend: false });
        }
      });
      const lim = r.limits[kind] ? Math.min(...r.limits[kind]) : null;
      rows.push([label, dataRange(ys, lim), kind]);
    });
    const h = 1 / rows.length;
    rows.forEach(([label, range], row) => {
      const name = row === 0 ? "yaxis" : `yaxis${row + 1}`;
      const top0 = 1 - row * h;
      layout[name] = { domain: [top0 - h + 0.04, top0 - 0.01], title: { text: label }, anchor: "x" };
      if (range) layout[name].range = range; else layout[name].range = [0, top];
    });
    Plotly.newPlot(div, traces, layout, { responsive: true, displaylogo: false });
    div.on("plotly_click", (ev) => { if (ev.points.length) select(ev.points[0].x, k); });
    views.time[k] = div;
  }

  function distanceFigure(div) {
    const traces = [];
    const layout = { height: info.kind === "compare" ? 720 : 320, margin: { l: 70, r: 20, t: 30, b: 40 },
      hovermode: "closest", legend: { orientation: "h", y: 1.08 },
      xaxis: { title: { text: "distance along the path mm" + (info.kind === "compare" ? ` (${info.runs[0].name})` : "") } } };
    info.runs.forEach((r0, k) => {
      const r = run(k), W = r.width, scale = k === 0 ? 1 : 1 / ratio();
      const pp = A[`r${k}_path_period`], ps = A[`r${k}_path_s`];
      const sOf = (p) => { const i = floorIndex(pp, p), j = Math.min(i + 1, pp.length - 1);
        const f = pp[j] > pp[i] ? (p - pp[i]) / (pp[j] - pp[i]) : 0; return (ps[i] + f * (ps[j] - ps[i])) * scale; };
      const nb = A[`r${k}_env_reason`].length;
      const xs = new Float64Array(nb + 1);
      for (let b = 0; b <= nb; b++) xs[b] = sOf(Math.min(b * W, r.periods - 1));
      const feed = envelopeXY(`r${k}_env_`, r.signals.length, 0, sOf);
      let top = 0;
      for (let i = 0; i < feed.y.length; i++) if (feed.y[i] > top) top = feed.y[i];
      if (info.kind === "run") traces.push(...reasonBands(k, `r${k}_env_`, xs, top * 1.08 || 1, "y", "x"));
      traces.push({ type: "scattergl", mode: "lines", x: feed.x, y: feed.y, name: `feed ${r.name}`,
        line: { color: info.kind === "run" ? "#000" : RUN_COLOURS[k], width: 1 } });
    });
    layout.yaxis = { title: { text: "feed mm/s" } };
    if (info.kind === "compare") {
      layout.yaxis.domain = [0.56, 1];
      const c = info.compare, pp = A.r0_path_period, ps = A.r0_path_s;
      layout.xaxis.anchor = `y${c.signals.length + 1}`;
      const sOf = (p) => { const i = floorIndex(pp, p), j = Math.min(i + 1, pp.length - 1);
        const f = pp[j] > pp[i] ? (p - pp[i]) / (pp[j] - pp[i]) : 0; return ps[i] + f * (ps[j] - ps[i]); };
      c.signals.forEach((label, j) => {
        const e = envelopeXY("d_env_", c.signals.length, j, sOf);
        const yaxis = `y${j + 2}`;
        const what = j ? "distance from the first path to the second" : "feed of the second minus the first";
        traces.push({ type: "scattergl", mode: "lines", x: e.x, y: e.y, name: `${label}: ${what}`, yaxis,
          line: { color: j ? "#6a1b9a" : "#2e7d32", width: 1 } });
        layout[`yaxis${j + 2}`] = { domain: j ? [0, 0.2] : [0.26, 0.5], title: { text: label }, anchor: "x" };
      });
    }
    Plotly.newPlot(div, traces, layout, { responsive: true, displaylogo: false });
    div.on("plotly_click", (ev) => { if (ev.points.length) selectDistance(ev.points[0].x); });
    views.dist = div;
  }

  function discreteScale(colours) {
    const n = colours.length, out = [];
    colours.forEach((c, i) => { out.push([i / n, c], [(i + 1) / n, c]); });
    return out;
  }

  // one run's path split into cuts and rapids (NaN breaks); idx maps a trace point back to its path point
  function pathTraces(k) {
    const xyz = A[`r${k}_path_xyz`], rapid = A[`r${k}_path_rapid`], feed = A[`r${k}_path_feed`],
      limit = A[`r${k}_path_limit`];
    const parts = [[], []];
    const n = rapid.length;
    for (let i = 1; i < n; i++) {
      const part = parts[rapid[i] ? 1 : 0];
      if (!part.length || part[part.length - 1] !== i - 1) { if (part.length) part.push(-1); part.push(i - 1); }
      part.push(i);
    }
    return parts.map((idx) => {
      const x = new Float32Array(idx.length), y = new Float32Array(idx.length), z = new Float32Array(idx.length);
      const f = new Float32Array(idx.length), c = new Float32Array(idx.length);
      idx.forEach((i, q) => {
        if (i < 0) { x[q] = y[q] = z[q] = NaN; return; }
        x[q] = xyz[3 * i]; y[q] = xyz[3 * i + 1]; z[q] = xyz[3 * i + 2]; f[q] = feed[i]; c[q] = limit[i];
      });
      return { idx, x, y, z, feed: f, reason: c };
    });
  }

  function pathFigure(div) {
    const traces = [], kinds = [];
    info.runs.forEach((r, k) => {
      const [cut, rapid] = pathTraces(k);
      const single = info.kind === "run";
      traces.push({ type: "scatter3d", mode: "lines", name: `${single ? "" : r.name + " "}cuts`, x: cut.x, y: cut.y, z: cut.z,
        line: single ? { color: cut.feed, colorscale: "Viridis", width: 4, showscale: true,
          colorbar: { title: { text: "feed mm/s" } } } : { color: RUN_COLOURS[k], width: 4 },
        hoverinfo: "x+y+z+name" });
      kinds.push(["cut", k, cut]);
      traces.push({ type: "scatter3d", mode: "lines", name: `${single ? "" : r.name + " "}rapids`, x: rapid.x, y: rapid.y,
        z: rapid.z, line: { color: "#888", width: 2, dash: "dash" }, hoverinfo: "x+y+z+name" });
      kinds.push(["rapid", k, rapid]);
      if (r.surface) {
        const sx = A[`r${k}_surf_x`], sy = A[`r${k}_surf_y`], sz = A[`r${k}_surf_z`], nx = sx.length;
        const z = [];
        for (let j = 0; j < sy.length; j++) z.push(Array.from(sz.subarray(j * nx, (j + 1) * nx)));
        traces.push({ type: "surface", name: "workpiece", x: Array.from(sx), y: Array.from(sy), z,
          colorscale: "Greys", showscale: false, opacity: 0.9 });
        kinds.push(["surface", k, null]);
      }
    });
    info.runs.forEach((r, k) => {
      views.toolTrace[k] = traces.length;
      const p = A[`r${k}_path_xyz`];
      traces.push({ type: "scatter3d", mode: "markers", name: `tool ${info.runs.length > 1 ? r.name : ""}`,
        x: [p[0]], y: [p[1]], z: [p[2]], marker: { size: 6, color: RUN_COLOURS[k], symbol: "diamond" } });
      kinds.push(["tool", k, null]);
    });
    const layout = { height: 560, margin: { l: 0, r: 0, t: 10, b: 0 }, legend: { x: 0, y: 1 },
      scene: { aspectmode: "data", xaxis: { title: { text: "X mm" } }, yaxis: { title: { text: "Y mm" } },
        zaxis: { title: { text: "Z mm" } } } };
    Plotly.newPlot(div, traces, layout, { responsive: true, displaylogo: false });
    div.on("plotly_click", (ev) => {
      const pt = ev.points[0];
      if (!pt) return;
      const [kind, k, part] = kinds[pt.curveNumber];
      if (kind !== "cut" && kind !== "rapid") return;
      const i = part.idx[pt.pointNumber];
      if (i >= 0) select((A[`r${k}_path_period`][i] + 1) * run(k).period_s, k);
    });
    views.path = div;
    views.pathKinds = kinds;
  }

  function colourBy(mode) {
    if (info.kind !== "run") return;
    const cut = views.pathKinds[0][2];
    const line = mode === "reason"
      ? { color: cut.reason, colorscale: discreteScale(info.limit_colours), cmin: -0.5, cmax: info.limit_colours.length - 0.5,
        width: 4, showscale: true, colorbar: { title: { text: "limit" }, tickvals: info.limit_names.map((_, i) => i),
          ticktext: info.limit_names } }
      : { color: cut.feed, colorscale: "Viridis", width: 4, showscale: true, colorbar: { title: { text: "feed mm/s" } } };
    Plotly.restyle(views.path, { line: [line] }, [0]);
  }

  function table(rows, head) {
    const t = el("table");
    if (head) { const tr = el("tr"); head.forEach((h) => tr.append(el("th", {}, h))); t.append(tr); }
    rows.forEach((row) => {
      const tr = el("tr");
      row.forEach((c, i) => tr.append(el("td", { className: i ? "num" : "" }, c)));
      t.append(tr);
    });
    return t;
  }

  function show_value(v) {
    if (v === null || v === undefined) return "-";
    if (Array.isArray(v)) return v.join("  ");
    if (typeof v === "object") return Object.entries(v).map(([a, b]) => `${a} ${b}`).join(", ");
    return String(v);
  }

  function build() {
    const body = document.body;
    const r0 = run(0);
    const title = info.kind === "run" ? `vcnc run ${r0.file}: ${r0.summary.state || ""}`
      : `vcnc compare ${info.runs[0].file} ${info.runs[1].file}`;
    body.append(el("h1", {}, title));
    body.append(el("div", { id: "pick" }, "click a point in any view (or move the time slider) to see the program line"));
    const controls = el("div", { className: "controls" });
    if (info.kind === "run") {
      const slider = el("input", { type: "range", id: "tslider", min: 0, max: r0._total_s, step: r0.period_s, value: 0 });
      slider.addEventListener("input", () => select(Number(slider.value), 0));
      controls.append(el("label", {}, "tool at time "), slider);
      const sel = el("select", { id: "colourby" });
      sel.append(el("option", { value: "feed" }, "cuts coloured by feed"), el("option", { value: "reason" }, "cuts coloured by limiting reason"));
      sel.addEventListener("change", () => colourBy(sel.value));
      controls.append(sel);
    }
    body.append(controls);
    body.append(el("h2", {}, "path (rapids dashed)"));
    const p3 = el("div", { id: "path3d", className: "plot" });
    body.append(p3);
    if (info.kind === "run") {
      body.append(el("h2", {}, "against time: feed shaded by its limiting reason; axis velocity, acceleration, jerk (dashed: limits)"));
      const tdiv = el("div", { id: "time0", className: "plot" });
      body.append(tdiv);
    }
    body.append(el("h2", {}, info.kind === "run" ? "feed against distance" : "aligned by distance: feeds and differences"));
    const ddiv = el("div", { id: "dist", className: "plot" });
    body.append(ddiv);
    pathFigure(p3);
    if (info.kind === "run") timeFigure(0, document.getElementById("time0"));
    distanceFigure(ddiv);
    if (info.kind === "compare") {
      body.append(el("h2", {}, "figures"));
      body.append(table(info.compare.table, ["", info.runs[0].name, info.runs[1].name]));
    }
    info.runs.forEach((r) => {
      body.append(el("h2", {}, `run summary: ${r.name}`));
      body.append(table(Object.entries(r.summary).map(([k, v]) => [k, show_value(v)])));
      const notes = [...r.warnings, ...r.messages];
      body.append(el("h2", {}, `warnings, notices and messages: ${r.name}`));
      if (!notes.length) body.append(el("p", {}, "none"));
      notes.forEach((w) => body.append(el("div", { className: "warn" }, w)));
    });
    const m = r0.machine;
    if (m && m.text) {
      body.append(el("h2", {}, `machine file: ${m.path}`));
      const d = el("details");
      d.append(el("summary", {}, "show"), el("pre", {}, m.text));
      body.append(d);
    }
    body.append(el("p", {}, `written ${info.written}`));
  }

  window.vcncReport = { ready: false, info, select: (t, k) => select(t, k || 0), selectDistance };
  unpack().then((arrays) => {
    A = arrays;
    window.vcncReport.arrays = A;
    build();
    window.vcncReport.ready = true;
  }).catch((err) => {
    document.body.append(el("p", { id: "error" }, `the report could not be drawn: ${err}`));
    console.error(err);
  });
})();
