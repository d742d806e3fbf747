// Shows a vlf-bake export. URL parameters: file (GLB, default cornell-box.glb), size (WxH,
// default the window), still (no orbit controls: the glTF camera as it is), exposure (stops, default 0), tonemap (clamp | aces, default clamp),
// camera (index of the glTF camera, default 0; a view of the whole scene when it has none),
// and, for the browser test's checks only, break=lightmap (no lightmap bound) or break=flipv
// (EXR rows left bottom-up).

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import {
  MozLightmap, VlfTextureExr, decodeRgbmLightmaps, useVlfToneMapping,
} from './vlf-lightmap.js';

const params = new URLSearchParams(location.search);
const status = document.getElementById('status');
const canvas = document.getElementById('view');
const brk = params.get('break');

async function main() {
  const [w, h] = (params.get('size') || `${innerWidth}x${innerHeight}`).split('x').map(Number);
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(w, h, false);
  canvas.style.width = `${w}px`;
  canvas.style.height = `${h}px`;
  useVlfToneMapping(renderer, params.get('tonemap') || 'clamp', Number(params.get('exposure') || 0));

  const loader = new GLTFLoader();
  loader.register((p) => new VlfTextureExr(p, { flipRows: brk !== 'flipv' }));
  loader.register((p) => new MozLightmap(p, { skip: brk === 'lightmap' }));
  const gltf = await loader.loadAsync(params.get('file') || 'cornell-box.glb');
  const scene = gltf.scene;
  decodeRgbmLightmaps(scene);
  scene.background = new THREE.Color(0, 0, 0);

  let camera = gltf.cameras[Number(params.get('camera') || 0)];
  if (camera) {
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  } else {
    const box = new THREE.Box3().setFromObject(scene);
    const centre = box.getCenter(new THREE.Vector3());
    const radius = box.getSize(new THREE.Vector3()).length() / 2;
    camera = new THREE.PerspectiveCamera(45, w / h, radius / 100, radius * 10);
    camera.position.copy(centre).add(new THREE.Vector3(0, radius * 0.5, radius * 2));
    camera.lookAt(centre);
  }
  if (!params.has('still')) {
    // Orbit round a point ahead of the camera (in world space: the camera leaves its node).
    scene.updateMatrixWorld(true);
    const eye = camera.getWorldPosition(new THREE.Vector3());
    const quat = camera.getWorldQuaternion(new THREE.Quaternion());
    scene.attach(camera);
    camera.position.copy(eye);
    camera.quaternion.copy(quat);
    const controls = new OrbitControls(camera, canvas);
    controls.target.copy(eye).add(new THREE.Vector3(0, 0, -1).applyQuaternion(quat));
    controls.update();
    controls.addEventListener('change', () => renderer.render(scene, camera));
  }

  renderer.render(scene, camera);
  const extras = gltf.parser.json.extras && gltf.parser.json.extras.vlf;
  status.textContent = extras ? `${extras.source} · lightmap ${extras.lightmap.encoding}` : 'no vlf extras';
  if (params.has('still')) {
    // For the browser test (chromium --dump-dom): the canvas as it was drawn.
    status.remove();
    document.body.dataset.png = canvas.toDataURL('image/png');
  }
  document.body.dataset.done = '1';
}

main().catch((e) => {
  status.textContent = `error: ${e}`;
  document.body.dataset.error = String(e);
  console.error(e);
});
