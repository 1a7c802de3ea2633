// The interactive view of a dsnake run in report.html (docs/reports.md): the final mesh (3D) or
// contour (2D), coloured per vertex by a scalar in mm (error where the ground truth gives the
// vertex's true position, else displacement), the placed template on request, and a colour
// legend. esbuild bundles this file with three.js into one minified IIFE that defines the global
// DsnakeViewer (viewer/CMakeLists.txt), which make_report.py inlines into the page.
//
//   DsnakeViewer.show(element, data) -> handle {setScalar(name), setInitialVisible(on), reset(),
//                                               render(), renderer}, or null without WebGL
//
// `element` is a <div> (the viewer fills it) or a <canvas>; `data` is the JSON make_report.py
// writes (scripts/report/make_report.py, mesh_payload): {dimension, unit, colour_by, scalars:
// {name: {label, min, max}}, meshes: {final: {...}, initial: {...}}}, each mesh with
// base64-encoded little-endian typed arrays {dtype, b64}: positions (x, y, z per vertex), cells
// (vertex indices: three per triangle, or two per line segment) and per-vertex scalars (NaN
// where a vertex has no value). The element's data-dsnake-viewer attribute becomes "drawn" after
// the first frame, or "unavailable" when the browser has no WebGL (a note replaces the view).
import {
  Box3,
  BufferAttribute,
  BufferGeometry,
  Color,
  DirectionalLight,
  DoubleSide,
  Float32BufferAttribute,
  HemisphereLight,
  LineBasicMaterial,
  LineSegments,
  Mesh,
  MeshLambertMaterial,
  PerspectiveCamera,
  Points,
  PointsMaterial,
  Scene,
  Vector3,
  WebGLRenderer,
  WireframeGeometry,
} from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

// matplotlib's viridis at 0, 1/8, ..., 1 (the colour map of render.png), interpolated linearly.
const VIRIDIS = ['#440154', '#472d7b', '#3b528b', '#2c728e', '#21918c', '#28ae80', '#5ec962', '#addc30', '#fde725']
  .map((hex) => new Color(hex));
const NO_VALUE = new Color(0.72, 0.72, 0.72);  // vertices without a value, as in render.png
const TEMPLATE = new Color('#e0b000');  // the placed template: yellow, as in overlay.png and slices.png
const BACKGROUND = new Color('#ffffff');
const TYPES = { f32: Float32Array, u32: Uint32Array, u16: Uint16Array, u8: Uint8Array };

// A typed array from {dtype, b64}.
function decode(array) {
  const text = atob(array.b64);
  const bytes = new Uint8Array(text.length);
  for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i);
  return new TYPES[array.dtype](bytes.buffer);
}

function viridis(t, out) {
  const x = Math.min(Math.max(t, 0), 1) * (VIRIDIS.length - 1);
  const i = Math.min(Math.floor(x), VIRIDIS.length - 2);
  return out.copy(VIRIDIS[i]).lerp(VIRIDIS[i + 1], x - i);
}

// Per-vertex RGB for `values` on [min, max]; NaN gets the no-value grey.
function vertexColours(values, min, max) {
  const rgb = new Float32Array(values.length * 3);
  const c = new Color();
  const span = max > min ? max - min : 1;
  for (let i = 0; i < values.length; i++) {
    if (Number.isFinite(values[i])) viridis((values[i] - min) / span, c);
    else c.copy(NO_VALUE);
    c.toArray(rgb, 3 * i);
  }
  return rgb;
}

function geometryOf(mesh) {
  const g = new BufferGeometry();
  g.setAttribute('position', new BufferAttribute(decode(mesh.positions), 3));
  g.setIndex(new BufferAttribute(decode(mesh.cells), 1));
  return g;
}

// The final shape: a lit surface (3D) or coloured line segments with their vertices (2D).
function finalObject(mesh, dimension) {
  const g = geometryOf(mesh);
  g.setAttribute('color', new Float32BufferAttribute(new Float32Array(mesh.vertex_count * 3), 3));
  if (dimension === 3) {
    g.computeVertexNormals();
    // Pushed back a little in depth, so that the marks of valued vertices lie on top of it.
    const material = new MeshLambertMaterial({ vertexColors: true, side: DoubleSide, polygonOffset: true,
      polygonOffsetFactor: 2, polygonOffsetUnits: 4 });
    const surface = new Mesh(g, material);
    // When only some vertices have a value (error: the template's vertices among those that
    // remeshing inserted), each valued vertex is also drawn as a dot of its colour.
    const marks = new BufferGeometry();
    marks.setAttribute('position', g.getAttribute('position'));
    marks.setAttribute('color', g.getAttribute('color'));
    const dots = new PointsMaterial({ vertexColors: true, size: 6, sizeAttenuation: false });
    surface.userData.marks = new Points(marks, dots);
    surface.add(surface.userData.marks);
    return surface;
  }
  const lines = new LineSegments(g, new LineBasicMaterial({ vertexColors: true }));
  lines.add(new Points(g, new PointsMaterial({ vertexColors: true, size: 5, sizeAttenuation: false })));
  return lines;
}

// The placed template: a yellow wireframe (3D) or contour (2D), hidden until asked for.
function initialObject(mesh, dimension) {
  const g = geometryOf(mesh);
  // In 3D drawn over the surface (no depth test), so that the whole template shows where it started.
  const material = new LineBasicMaterial({ color: TEMPLATE, transparent: dimension === 3, opacity: 0.6,
    depthTest: dimension !== 3 });
  const object = new LineSegments(dimension === 3 ? new WireframeGeometry(g) : g, material);
  object.visible = false;
  return object;
}

function element(tag, style, text) {
  const e = document.createElement(tag);
  if (style) e.style.cssText = style;
  if (text !== undefined) e.textContent = text;
  return e;
}

// Three ticks (min, middle, max) in the data's unit, to three significant digits.
function tickText(v) {
  return Number(v.toPrecision(3)).toString();
}

// The colour legend: a viridis bar from min to max, its ticks, and the no-value grey when used.
function drawLegend(legend, scalar, unit, hasNoValue) {
  legend.textContent = '';
  legend.appendChild(element('div', 'font-weight:600', `${scalar.name} (${unit})`));
  legend.appendChild(element('div', 'margin-bottom:2px', scalar.label));
  const bar = element('canvas', 'display:block;width:240px;height:12px;border:1px solid #888');
  bar.width = 240;
  bar.height = 12;
  const ctx = bar.getContext('2d');
  const c = new Color();
  for (let x = 0; x < bar.width; x++) {
    ctx.fillStyle = `#${viridis(x / (bar.width - 1), c).getHexString()}`;
    ctx.fillRect(x, 0, 1, bar.height);
  }
  legend.appendChild(bar);
  const ticks = element('div', 'display:flex;justify-content:space-between;width:242px');
  for (const v of [scalar.min, (scalar.min + scalar.max) / 2, scalar.max]) {
    ticks.appendChild(element('span', '', tickText(v)));
  }
  legend.appendChild(ticks);
  if (hasNoValue) {
    const note = element('div', 'margin-top:3px');
    note.appendChild(element('span', 'display:inline-block;width:12px;height:12px;vertical-align:middle;'
      + `border:1px solid #888;background:#${NO_VALUE.getHexString()}`));
    note.appendChild(document.createTextNode(` ${scalar.no_value || 'no value'}`));
    legend.appendChild(note);
  }
}

// The element that holds the canvas and the controls; a given <canvas> keeps its place.
function layout(target) {
  const isCanvas = target instanceof HTMLCanvasElement;
  const root = isCanvas ? element('div', 'position:relative') : target;
  if (isCanvas) target.replaceWith(root);
  root.style.position = 'relative';
  const canvas = isCanvas ? target : element('canvas');
  canvas.style.display = 'block';
  canvas.style.width = '100%';
  canvas.style.height = isCanvas ? canvas.style.height || `${canvas.height || 480}px` : '100%';
  const panel = 'position:absolute;left:6px;background:rgba(255,255,255,0.85);padding:4px 6px;border-radius:4px;';
  const toolbar = element('div', `${panel}top:6px;font:13px sans-serif`);
  const legend = element('div', `${panel}bottom:6px;font:12px sans-serif`);
  root.append(canvas, toolbar, legend);
  return { root, canvas, toolbar, legend };
}

// The camera framing the shapes: 3D from the front (anterior, -y in LPS) and a little from the
// side and above, superior (+z) up, so that the patient's left is on the right as in the
// radiological convention; 2D from -z with x to the right and y down, as overlay.png draws the
// image. The distance is the least at which every vertex is in view, with a margin for the
// toolbar and the legend: a vertex at height h and depth z toward the camera needs
// distance >= margin h / tan(fov / 2) + z.
function frame(camera, controls, positions, dimension) {
  const box = new Box3();
  for (const p of positions) box.union(new Box3().setFromArray(p));
  const centre = box.getCenter(new Vector3());
  camera.up.set(0, dimension === 3 ? 0 : -1, dimension === 3 ? 1 : 0);
  const direction = dimension === 3 ? new Vector3(0.35, -1, 0.3).normalize() : new Vector3(0, 0, -1);
  const right = new Vector3().crossVectors(camera.up, direction).normalize();
  const up = new Vector3().crossVectors(direction, right).normalize();
  const tanY = Math.tan((camera.fov * Math.PI) / 360) / 1.3;
  const tanX = tanY * camera.aspect;
  const v = new Vector3();
  let distance = 1e-6;
  for (const p of positions) {
    for (let i = 0; i < p.length; i += 3) {
      v.set(p[i], p[i + 1], p[i + 2]).sub(centre);
      const across = Math.max(Math.abs(v.dot(up)) / tanY, Math.abs(v.dot(right)) / tanX);
      distance = Math.max(distance, across + v.dot(direction));
    }
  }
  camera.position.copy(centre).addScaledVector(direction, distance);
  camera.near = distance / 100;
  camera.far = distance * 100;
  camera.updateProjectionMatrix();
  controls.target.copy(centre);
  controls.update();
}

function toolbarControls(ui, data, actions) {
  const names = Object.keys(data.scalars);
  const select = element('select', 'margin-left:4px');
  select.className = 'dsnake-scalar';
  for (const n of names) {
    select.appendChild(new Option(`${data.scalars[n].name} (${data.unit})`, n, false, n === data.colour_by));
  }
  select.addEventListener('change', () => actions.setScalar(select.value));
  ui.toolbar.append(document.createTextNode('colour: '), select);
  if (data.meshes.initial) {
    const label = element('label', 'margin-left:10px');
    const box = element('input');
    box.type = 'checkbox';
    box.className = 'dsnake-initial';
    box.addEventListener('change', () => actions.setInitialVisible(box.checked));
    label.append(box, document.createTextNode(' placed template'));
    ui.toolbar.appendChild(label);
  }
  const reset = element('button', 'margin-left:10px', 'reset view');
  reset.addEventListener('click', actions.reset);
  ui.toolbar.appendChild(reset);
}

function createRenderer(ui) {
  try {
    const renderer = new WebGLRenderer({ canvas: ui.canvas, antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setClearColor(BACKGROUND, 1);
    return renderer;
  } catch (e) {
    // No WebGL (a browser with it turned off): say so in place of the view, not as a page error.
    ui.root.textContent = `The 3D view needs WebGL, which this browser does not provide (${e.message}).`;
    ui.root.dataset.dsnakeViewer = 'unavailable';
    return null;
  }
}

function sceneOf(data, camera) {
  const scene = new Scene();
  scene.add(new HemisphereLight(0xffffff, 0x555555, 1.6));
  const light = new DirectionalLight(0xffffff, 1.4);
  light.position.set(0.3, 0.4, 1);
  camera.add(light);  // a head light: the side in view is lit whatever the rotation
  scene.add(camera);
  const final = finalObject(data.meshes.final, data.dimension);
  scene.add(final);
  const initial = data.meshes.initial ? initialObject(data.meshes.initial, data.dimension) : null;
  if (initial) scene.add(initial);
  return { scene, final, initial };
}

export function show(target, data) {
  const ui = layout(target);
  const renderer = createRenderer(ui);
  if (!renderer) return null;
  const camera = new PerspectiveCamera(30, 1, 0.1, 1000);
  const { scene, final, initial } = sceneOf(data, camera);
  const controls = new OrbitControls(camera, ui.canvas);
  controls.enableRotate = data.dimension === 3;
  controls.screenSpacePanning = true;
  const positions = [final, initial].filter(Boolean).map((o) => o.geometry.getAttribute('position').array);
  const render = () => {
    renderer.render(scene, camera);
    ui.root.dataset.dsnakeViewer = 'drawn';
  };
  const fit = () => {
    const w = Math.max(ui.canvas.clientWidth, 1);
    const h = Math.max(ui.canvas.clientHeight, 1);
    renderer.setSize(w, h, false);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  };
  const resize = () => {
    fit();
    render();
  };
  const handle = {
    renderer,
    render,
    setScalar(name) {
      const scalar = data.scalars[name];
      const values = decode(data.meshes.final.scalars[name]);
      final.geometry.getAttribute('color').copyArray(vertexColours(values, scalar.min, scalar.max)).needsUpdate = true;
      const marks = final.userData.marks;
      if (marks) {
        const valued = [];
        values.forEach((v, i) => Number.isFinite(v) && valued.push(i));
        marks.geometry.setIndex(valued);
        marks.visible = valued.length > 0 && valued.length < values.length;
      }
      drawLegend(ui.legend, scalar, data.unit, values.some((v) => !Number.isFinite(v)));
      render();
    },
    setInitialVisible(on) {
      if (initial) initial.visible = on;
      render();
    },
    reset() {
      frame(camera, controls, positions, data.dimension);
      render();
    },
  };
  toolbarControls(ui, data, handle);
  controls.addEventListener('change', render);
  fit();
  frame(camera, controls, positions, data.dimension);
  handle.setScalar(data.colour_by);
  if (typeof ResizeObserver === 'function') new ResizeObserver(resize).observe(ui.canvas);
  resize();
  return handle;
}
