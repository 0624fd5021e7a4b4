// The 3D view (three.js): board, pegs, both tools, the last point cloud, perception's blocks and, from the
// simulator, its ground truth (wireframe, labelled in the legend). The server sends the board frame (z down
// into the board); the scene turns it up with a half turn about x. Rendered on demand, not every frame.

import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";

const ARM_COLOURS = { PSM1: 0x4cc38a, PSM2: 0xb07cf0 };
const TOOL_RADII = [0.004, 0.0025, 0.0015]; // shaft, wrist, jaw (m): for drawing only

export class WorldView {
  constructor(container, legend) {
    this.container = container;
    this.legend = legend;
    this.samples = [];
    this.ready = false;
    try {
      this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    } catch (error) {
      container.innerHTML = '<div class="note">no WebGL in this browser: the 3D view is off</div>';
      return;
    }
    this.renderer.setPixelRatio(window.devicePixelRatio);
    container.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x20252e);
    this.frame = new THREE.Group();
    this.frame.rotation.x = Math.PI; // board frame (z down) to the view's (z up)
    this.scene.add(this.frame);
    this.scene.add(new THREE.AmbientLight(0xffffff, 1.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(0.2, -0.3, 0.5);
    this.scene.add(sun);
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.005, 5);
    this.camera.up.set(0, 0, 1);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener("change", () => this.render());
    new ResizeObserver(() => this.resize()).observe(container);
    this.container.innerHTML = "";
    this.container.appendChild(this.renderer.domElement);
    this.note = document.createElement("div");
    this.note.className = "note";
    this.note.style.position = "absolute";
    this.note.style.top = "0";
    this.note.textContent = "no world in this run (a tree without arms, or a log without a world sidecar)";
    this.container.appendChild(this.note);
  }

  setScene(scene) {
    if (!this.renderer) return;
    this.note.remove();
    const { board, pegs, block } = scene;
    const width = board.x[1] - board.x[0], depth = board.y[1] - board.y[0];
    const slab = new THREE.Mesh(
      new THREE.BoxGeometry(width, depth, board.thickness),
      new THREE.MeshStandardMaterial({ color: 0x8a6a4a }),
    );
    slab.position.set((board.x[0] + board.x[1]) / 2, (board.y[0] + board.y[1]) / 2, board.z + board.thickness / 2);
    this.frame.add(slab);
    const pegMaterial = new THREE.MeshStandardMaterial({ color: 0xd8d8d8 });
    for (const [x, y, top] of pegs.tops) {
      const length = pegs.base_z - top;
      const peg = new THREE.Mesh(new THREE.CylinderGeometry(pegs.radius, pegs.radius, length, 16), pegMaterial);
      peg.rotation.x = Math.PI / 2;
      peg.position.set(x, y, top + length / 2);
      this.frame.add(peg);
    }
    const shape = new THREE.Shape(block.outline.map(([x, y]) => new THREE.Vector2(x, y)));
    this.blockGeometry = new THREE.ExtrudeGeometry(shape, { depth: block.height, bevelEnabled: false });
    this.blockGeometry.translate(0, 0, -block.height); // block frame: bottom face at z = 0, top at -height
    this.believed = new THREE.Group();
    this.truth = new THREE.Group();
    this.tools = new THREE.Group();
    this.cloud = new THREE.Points(
      new THREE.BufferGeometry(),
      new THREE.PointsMaterial({ color: 0x9fb3c8, size: 0.0012 }),
    );
    this.frame.add(this.believed, this.truth, this.tools, this.cloud);
    const centre = new THREE.Vector3((board.x[0] + board.x[1]) / 2, -(board.y[0] + board.y[1]) / 2, -board.z);
    this.camera.position.set(centre.x + 0.05, centre.y - 0.16, centre.z + 0.13);
    this.controls.target.copy(centre);
    this.controls.update();
    this.ready = true;
    this.resize();
  }

  addSample(sample) {
    this.samples.push(sample);
  }

  // Show the world as it was after tick `tick`: the latest sample of each kind at or before it.
  showTick(tick) {
    if (!this.ready) return;
    const latest = {};
    for (const sample of this.samples) {
      if (sample.n > tick) break;
      latest.tools = sample.tools;
      for (const kind of ["cloud", "blocks", "truth"]) if (sample[kind]) latest[kind] = sample[kind];
    }
    this.drawTools(latest.tools || {});
    this.drawCloud(latest.cloud || []);
    this.drawBlocks(this.believed, latest.blocks || [], false);
    this.drawBlocks(this.truth, latest.truth || [], true);
    this.legend.textContent =
      "perception's blocks: solid blue" + (latest.truth ? " · simulator's ground truth: orange wireframe" : "");
    this.render();
  }

  drawTools(tools) {
    this.tools.clear();
    for (const [arm, points] of Object.entries(tools)) {
      const material = new THREE.MeshStandardMaterial({ color: ARM_COLOURS[arm] || 0xffffff });
      for (let i = 0; i + 1 < points.length; i++) {
        const a = new THREE.Vector3(...points[i]), b = new THREE.Vector3(...points[i + 1]);
        const length = a.distanceTo(b);
        const radius = TOOL_RADII[Math.min(i, TOOL_RADII.length - 1)];
        const rod = new THREE.Mesh(new THREE.CylinderGeometry(radius, radius, length, 10), material);
        rod.position.copy(a).add(b).multiplyScalar(0.5);
        rod.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), b.clone().sub(a).normalize());
        this.tools.add(rod);
      }
    }
  }

  drawCloud(flat) {
    this.cloud.geometry.setAttribute("position", new THREE.Float32BufferAttribute(flat, 3));
    this.cloud.geometry.computeBoundingSphere();
  }

  drawBlocks(group, blocks, truth) {
    group.clear();
    const material = truth
      ? new THREE.MeshBasicMaterial({ color: 0xff9d3c, wireframe: true })
      : new THREE.MeshStandardMaterial({ color: 0x3d7fe0, transparent: true, opacity: 0.85 });
    for (const block of blocks) {
      const mesh = new THREE.Mesh(this.blockGeometry, material);
      if (truth) {
        mesh.matrixAutoUpdate = false;
        mesh.matrix.set(...block.pose.flat());
      } else {
        mesh.position.set(...block.position);
        mesh.rotation.z = block.yaw;
      }
      group.add(mesh);
    }
  }

  resize() {
    if (!this.renderer) return;
    const { clientWidth: width, clientHeight: height } = this.container;
    if (!width || !height) return;
    this.renderer.setSize(width, height);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.render();
  }

  render() {
    if (this.renderer) this.renderer.render(this.scene, this.camera);
  }
}
