// What Babylon.js's own glTF loader binds from a .glb, as one JSON object on stdout: each
// mesh's material and the textures in its slots (by name), its morph targets, and the
// animation groups with their first and last frames.  Run by
// tests/blender/test_export_engines.py:  node babylon_bindings.mjs FILE
// Babylon's NullEngine (no GPU) creates textures without decoding their pixels.
import fs from 'node:fs';
import { NullEngine } from '@babylonjs/core/Engines/nullEngine.js';
import { Scene } from '@babylonjs/core/scene.js';
import { LoadAssetContainerAsync } from '@babylonjs/core/Loading/sceneLoader.js';
import '@babylonjs/loaders/glTF/2.0/index.js';

const SLOTS = ['albedoTexture', 'bumpTexture', 'metallicTexture', 'reflectivityTexture', 'microSurfaceTexture',
    'ambientTexture', 'emissiveTexture', 'opacityTexture', 'lightmapTexture', 'diffuseTexture'];
const file = process.argv[2];
const engine = new NullEngine();
const scene = new Scene(engine);
const bytes = new Uint8Array(fs.readFileSync(file));
const log = console.log;
console.log = () => {}; // Babylon's banner and loader notes would mix with the JSON
try {
    const c = await LoadAssetContainerAsync(bytes, scene, { pluginExtension: '.glb' });
    const meshes = c.meshes.filter((m) => m.getTotalVertices() > 0).map((m) => {
        const mats = m.material ? (m.material.subMaterials || [m.material]) : [];
        return {
            name: m.name, vertices: m.getTotalVertices(),
            morphTargets: m.morphTargetManager
                ? Array.from({ length: m.morphTargetManager.numTargets }, (_, i) => m.morphTargetManager.getTarget(i).name)
                : [],
            materials: mats.filter(Boolean).map((x) => {
                const slots = {};
                for (const s of SLOTS) if (s in x) slots[s] = x[s] ? x[s].name : null;
                return { name: x.name, type: x.getClassName(), slots, metadata: Object.keys((x.metadata && x.metadata.gltf && x.metadata.gltf.extras) || {}) };
            }),
        };
    });
    const animations = c.animationGroups.map((g) => ({ name: g.name, from: g.from, to: g.to,
        targets: g.targetedAnimations.length }));
    console.log = log;
    console.log(JSON.stringify({ meshes, animations }));
} catch (err) {
    console.log = log;
    console.error(String(err && err.stack || err));
    process.exit(1);
}
