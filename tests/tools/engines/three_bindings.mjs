// What three.js's own GLTFLoader binds from a .glb or .gltf, as one JSON object on stdout:
// each mesh's material and the textures in its slots (by name), its morph targets, and the
// animations' tracks with their first and last times.  Run by
// tests/blender/test_export_engines.py:  node three_bindings.mjs FILE
//
// Under Node there is no DOM to decode images: the loader's image loader is replaced by one
// that returns a Texture without pixels, so every texture the loader asks for is bound by
// name as in a browser (the binding is the loader's, only the decoding is skipped).
import fs from 'node:fs';
import path from 'node:path';
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';

globalThis.self ??= globalThis; // the loader reads self.URL for embedded images

const file = process.argv[2];
const SLOTS = ['map', 'normalMap', 'bumpMap', 'displacementMap', 'roughnessMap', 'metalnessMap',
    'aoMap', 'emissiveMap', 'alphaMap', 'clearcoatNormalMap', 'specularColorMap', 'specularIntensityMap',
    'sheenColorMap', 'transmissionMap', 'thicknessMap', 'iridescenceMap', 'anisotropyMap'];
const noDecode = {
    load(url, onLoad) { onLoad(new THREE.Texture({ width: 1, height: 1, src: url })); },
};
const loader = new GLTFLoader();
loader.register((parser) => {
    parser.textureLoader = noDecode;
    return { name: 'ewrinkles_no_decode' };
});

function material(m) {
    const slots = {};
    for (const s of SLOTS) if (s in m) slots[s] = m[s] ? m[s].name : null;
    return {
        name: m.name, type: m.type, slots,
        normalScale: m.normalScale ? [m.normalScale.x, m.normalScale.y] : null,
        color: m.color ? m.color.toArray() : null,
        userData: Object.keys(m.userData || {}),
    };
}

const data = fs.readFileSync(file);
const buffer = data.buffer.slice(data.byteOffset, data.byteOffset + data.byteLength);
loader.parse(buffer, path.dirname(path.resolve(file)) + '/', (gltf) => {
    const meshes = [];
    gltf.scene.traverse((o) => {
        if (!o.isMesh) return;
        const mats = Array.isArray(o.material) ? o.material : [o.material];
        meshes.push({
            name: o.name, parent: o.parent ? o.parent.name : null,
            vertices: o.geometry.attributes.position.count,
            attributes: Object.keys(o.geometry.attributes),
            morphTargets: Object.keys(o.morphTargetDictionary || {}),
            materials: mats.map(material),
        });
    });
    const animations = gltf.animations.map((a) => ({
        name: a.name, duration: a.duration,
        tracks: a.tracks.map((t) => ({ name: t.name, first: t.times[0], last: t.times[t.times.length - 1],
            count: t.times.length })),
    }));
    console.log(JSON.stringify({ meshes, animations }));
}, (err) => { console.error(String(err && err.stack || err)); process.exit(1); });
