// dexcut report: stock viewer. Parses the embedded GLB (JSON + BIN chunks),
// draws POSITION / NORMAL / COLOR_0 / indices with WebGL, drag to orbit,
// wheel to zoom. No external code.
(function () {
  "use strict";
  var holder = document.getElementById("stock-view");
  if (!holder) { return; }
  var note = holder.querySelector(".viewer-note");
  function say(msg) { note.textContent = msg; }

  function b64ToBytes(s) {
    var bin = atob(s), out = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) { out[i] = bin.charCodeAt(i); }
    return out;
  }

  function parseGlb(bytes) {
    var dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    if (bytes.byteLength < 12 || dv.getUint32(0, true) !== 0x46546C67) { throw new Error("embedded model is not a GLB"); }
    var total = Math.min(dv.getUint32(8, true), bytes.byteLength), off = 12, json = null, bin = null;
    while (off + 8 <= total) {
      var len = dv.getUint32(off, true), type = dv.getUint32(off + 4, true);
      var body = bytes.subarray(off + 8, off + 8 + len);
      if (type === 0x4E4F534A) { json = JSON.parse(new TextDecoder().decode(body)); }
      else if (type === 0x004E4942) { bin = body; }
      off += 8 + len;
    }
    if (!json) { throw new Error("GLB has no JSON chunk"); }
    return { json: json, bin: bin };
  }

  var TYPES = { 5120: Int8Array, 5121: Uint8Array, 5122: Int16Array, 5123: Uint16Array, 5125: Uint32Array, 5126: Float32Array };
  var COMPS = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4 };
  function accessor(glb, index) {
    var acc = glb.json.accessors[index], view = glb.json.bufferViews[acc.bufferView];
    var T = TYPES[acc.componentType], comps = COMPS[acc.type];
    if (!T || !comps) { throw new Error("unsupported accessor " + index); }
    if (view.byteStride && view.byteStride !== comps * T.BYTES_PER_ELEMENT) { throw new Error("interleaved accessors are not supported"); }
    var start = glb.bin.byteOffset + (view.byteOffset || 0) + (acc.byteOffset || 0);
    var copy = glb.bin.buffer.slice(start, start + acc.count * comps * T.BYTES_PER_ELEMENT); // aligned copy
    return { data: new T(copy), comps: comps, acc: acc };
  }

  // Column-major 4x4 matrices.
  function perspective(fovy, aspect, near, far) {
    var f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
    return [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0];
  }
  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function norm(a) { var l = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / l, a[1] / l, a[2] / l]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function lookAt(eye, target, up) {
    var z = norm(sub(eye, target)), x = norm(cross(up, z)), y = cross(z, x);
    return [x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0, -dot(x, eye), -dot(y, eye), -dot(z, eye), 1];
  }
  function mul(a, b) {
    var o = new Array(16);
    for (var c = 0; c < 4; c++) {
      for (var r = 0; r < 4; r++) {
        var s = 0;
        for (var k = 0; k < 4; k++) { s += a[k * 4 + r] * b[c * 4 + k]; }
        o[c * 4 + r] = s;
      }
    }
    return o;
  }

  var glb = parseGlb(b64ToBytes(document.getElementById("stock-glb").textContent.trim()));
  var prim = glb.json.meshes && glb.json.meshes[0] && glb.json.meshes[0].primitives[0];
  if (!prim || !glb.bin) { say("The stock is empty: nothing to show."); holder.dataset.viewer = "empty"; return; }

  var canvas = holder.querySelector("canvas");
  var dpr = window.devicePixelRatio || 1;
  canvas.width = Math.max(1, Math.round(canvas.clientWidth * dpr));
  canvas.height = Math.max(1, Math.round(canvas.clientHeight * dpr));
  var opts = { antialias: true, preserveDrawingBuffer: true };
  var gl = null, webgl2 = false;
  try { gl = canvas.getContext("webgl2", opts); webgl2 = !!gl; if (!gl) { gl = canvas.getContext("webgl", opts) || canvas.getContext("experimental-webgl", opts); } } catch (e) { gl = null; }
  if (!gl) { say("WebGL is not available in this browser: the 3D view is off (the GLB file opens in any glTF viewer)."); holder.dataset.viewer = "no-webgl"; return; }

  var pos = accessor(glb, prim.attributes.POSITION);
  var idx = accessor(glb, prim.indices);
  if (idx.data instanceof Uint32Array && !webgl2 && !gl.getExtension("OES_element_index_uint")) {
    say("This WebGL lacks 32-bit indices: the 3D view is off."); holder.dataset.viewer = "no-uint32"; return;
  }

  function shader(type, src) {
    var s = gl.createShader(type); gl.shaderSource(s, src); gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) { throw new Error("shader: " + gl.getShaderInfoLog(s)); }
    return s;
  }
  var prog = gl.createProgram();
  gl.attachShader(prog, shader(gl.VERTEX_SHADER,
    "attribute vec3 aPos; attribute vec3 aNrm; attribute vec4 aCol; uniform mat4 uMvp; varying vec3 vNrm; varying vec4 vCol;" +
    "void main() { gl_Position = uMvp * vec4(aPos, 1.0); vNrm = aNrm; vCol = aCol; }"));
  gl.attachShader(prog, shader(gl.FRAGMENT_SHADER,
    "precision mediump float; uniform vec3 uLight; varying vec3 vNrm; varying vec4 vCol;" +
    "void main() { float d = abs(dot(normalize(vNrm), uLight)); gl_FragColor = vec4(vCol.rgb * (0.35 + 0.65 * d), 1.0); }"));
  gl.linkProgram(prog);
  if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) { throw new Error("program: " + gl.getProgramInfoLog(prog)); }
  gl.useProgram(prog);

  function attribute(name, acc, fallback) {
    var loc = gl.getAttribLocation(prog, name);
    if (loc < 0) { return; }
    if (!acc) { gl.disableVertexAttribArray(loc); gl.vertexAttrib4fv(loc, fallback); return; }
    var buf = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, buf);
    gl.bufferData(gl.ARRAY_BUFFER, acc.data, gl.STATIC_DRAW);
    var type = acc.data instanceof Float32Array ? gl.FLOAT : acc.data instanceof Uint8Array ? gl.UNSIGNED_BYTE : gl.UNSIGNED_SHORT;
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, acc.comps, type, !!acc.acc.normalized, 0, 0);
  }
  var a = prim.attributes;
  attribute("aPos", pos);
  attribute("aNrm", a.NORMAL !== undefined ? accessor(glb, a.NORMAL) : null, [0, 0, 1, 0]);
  attribute("aCol", a.COLOR_0 !== undefined ? accessor(glb, a.COLOR_0) : null, [0.7, 0.7, 0.7, 1]);
  var ibuf = gl.createBuffer();
  gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ibuf);
  gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, idx.data, gl.STATIC_DRAW);
  var itype = idx.data instanceof Uint32Array ? gl.UNSIGNED_INT : idx.data instanceof Uint16Array ? gl.UNSIGNED_SHORT : gl.UNSIGNED_BYTE;

  var lo = pos.acc.min, hi = pos.acc.max;
  if (!lo || !hi) {
    lo = [Infinity, Infinity, Infinity]; hi = [-Infinity, -Infinity, -Infinity];
    for (var i = 0; i < pos.data.length; i++) { lo[i % 3] = Math.min(lo[i % 3], pos.data[i]); hi[i % 3] = Math.max(hi[i % 3], pos.data[i]); }
  }
  var center = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
  var radius = Math.max(1e-6, Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) / 2);
  var yaw = -Math.PI / 3, pitch = 0.6, dist = radius * 2.6;
  var uMvp = gl.getUniformLocation(prog, "uMvp"), uLight = gl.getUniformLocation(prog, "uLight");

  function draw() {
    var eye = [center[0] + dist * Math.cos(pitch) * Math.cos(yaw), center[1] + dist * Math.cos(pitch) * Math.sin(yaw), center[2] + dist * Math.sin(pitch)];
    var view = lookAt(eye, center, [0, 0, 1]);
    var proj = perspective(35 * Math.PI / 180, canvas.width / canvas.height, dist / 100, dist + radius * 4);
    gl.viewport(0, 0, canvas.width, canvas.height);
    gl.clearColor(0.96, 0.97, 0.98, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.uniformMatrix4fv(uMvp, false, new Float32Array(mul(proj, view)));
    gl.uniform3fv(uLight, new Float32Array(norm([eye[0] - center[0] + radius, eye[1] - center[1], eye[2] - center[2] + radius])));
    gl.drawElements(gl.TRIANGLES, idx.acc.count, itype, 0);
  }
  var pending = false;
  function redraw() { if (!pending) { pending = true; requestAnimationFrame(function () { pending = false; draw(); }); } }

  var drag = null;
  canvas.addEventListener("pointerdown", function (e) { drag = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); });
  canvas.addEventListener("pointerup", function () { drag = null; });
  canvas.addEventListener("pointermove", function (e) {
    if (!drag) { return; }
    yaw -= (e.clientX - drag[0]) * 0.01;
    pitch = Math.max(-1.55, Math.min(1.55, pitch + (e.clientY - drag[1]) * 0.01));
    drag = [e.clientX, e.clientY];
    redraw();
  });
  canvas.addEventListener("wheel", function (e) {
    e.preventDefault();
    dist = Math.max(radius * 0.05, Math.min(radius * 50, dist * Math.exp(e.deltaY * 0.001)));
    redraw();
  }, { passive: false });

  window.addEventListener("resize", function () {
    var w = Math.max(1, Math.round(canvas.clientWidth * dpr)), h = Math.max(1, Math.round(canvas.clientHeight * dpr));
    if (w !== canvas.width || h !== canvas.height) { canvas.width = w; canvas.height = h; redraw(); }
  });

  draw();
  // Self-check for tests: how many pixels differ from the background.
  var w = canvas.width, h = canvas.height, px = new Uint8Array(w * h * 4), inked = 0;
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
  for (var p = 0; p < px.length; p += 4) { if (Math.abs(px[p] - 245) > 6 || Math.abs(px[p + 2] - 250) > 6) { inked++; } }
  holder.dataset.viewer = "webgl" + (webgl2 ? "2" : "1");
  holder.dataset.meshPixels = String(inked);
  say("Drag to orbit, wheel to zoom. " + (pos.acc.count) + " vertices, " + (idx.acc.count / 3) + " triangles.");
})();
