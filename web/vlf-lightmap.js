// GLTFLoader plugins for vlf-bake exports (docs/ENGINES.md):
//
// * MOZ_lightmap {index, texCoord, intensity} on a material: the texture becomes the
//   material's lightMap on uv set `texCoord` (three.js: texture.channel), scaled by
//   `intensity`. three.js adds lightMap × intensity to the irradiance and shades it with
//   BRDF_Lambert = diffuseColor / π (no π on the lightmap itself since r155), which is the
//   convention of the export: the lightmap holds irradiance E.
// * VLF_texture_exr {bufferView, mimeType: "image/x-exr"} on a texture: the OpenEXR page in
//   that buffer view, decoded by three.js's EXRLoader (linear half float).
// * png-rgbm lightmaps (extras.vlf_lightmap.encoding == "png-rgbm", or an EXR export read
//   without the EXR): the shader decodes rgb · a · rgbmRange.

import * as THREE from 'three';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';

export class VlfTextureExr {
  constructor(parser, options = {}) {
    this.parser = parser;
    this.name = 'VLF_texture_exr';
    this.flipRows = options.flipRows ?? true;
  }

  loadTexture(textureIndex) {
    const def = this.parser.json.textures[textureIndex];
    const ext = def.extensions && def.extensions[this.name];
    if (!ext) return null;
    return this.parser.getDependency('bufferView', ext.bufferView).then((buffer) => {
      const exr = new EXRLoader().setDataType(THREE.HalfFloatType).parse(buffer);
      const { width, height, data } = exr;
      // EXRLoader puts the file's first line last (OpenGL's bottom-up rows); glTF's uv (0, 0)
      // is the image's first line, so put the lines back in file order.
      const rows = this.flipRows ? flipRows(data, width, height) : data;
      const texture = new THREE.DataTexture(rows, width, height, exr.format, exr.type);
      texture.colorSpace = THREE.LinearSRGBColorSpace;
      texture.magFilter = THREE.LinearFilter;
      texture.minFilter = THREE.LinearFilter;
      texture.generateMipmaps = false;
      texture.wrapS = texture.wrapT = THREE.ClampToEdgeWrapping;
      texture.flipY = false;
      texture.name = def.name || '';
      texture.needsUpdate = true;
      return texture;
    });
  }
}

function flipRows(data, width, height) {
  const out = new data.constructor(data.length);
  const line = data.length / height;
  for (let y = 0; y < height; y++) {
    out.set(data.subarray(y * line, (y + 1) * line), (height - 1 - y) * line);
  }
  return out;
}

export class MozLightmap {
  constructor(parser, options = {}) {
    this.parser = parser;
    this.name = 'MOZ_lightmap';
    this.skip = options.skip ?? false;
  }

  extendMaterialParams(materialIndex, params) {
    const def = this.parser.json.materials[materialIndex];
    const ext = def.extensions && def.extensions[this.name];
    if (!ext || this.skip) return Promise.resolve();
    params.lightMapIntensity = ext.intensity ?? 1.0;
    return this.parser.assignTexture(params, 'lightMap', {
      index: ext.index,
      texCoord: ext.texCoord ?? 1,
    });
  }
}

// RGBM lightmaps: decodes in the shader (the texture holds rgb and the multiplier a, linear).
export function decodeRgbmLightmaps(root) {
  root.traverse((object) => {
    const materials = object.material ? [].concat(object.material) : [];
    for (const m of materials) {
      const info = m.userData && m.userData.vlf_lightmap;
      if (!info || !m.lightMap || m.lightMap.isDataTexture) continue;
      const range = Number(info.rgbmRange).toFixed(6);
      m.lightMap.colorSpace = THREE.NoColorSpace;
      m.onBeforeCompile = (shader) => {
        shader.fragmentShader = shader.fragmentShader.replace(
          '#include <lights_fragment_maps>',
          THREE.ShaderChunk.lights_fragment_maps.replace(
            'vec3 lightMapIrradiance = lightMapTexel.rgb * lightMapIntensity;',
            `vec3 lightMapIrradiance = lightMapTexel.rgb * lightMapTexel.a * ${range} * lightMapIntensity;`,
          ),
        );
      };
      m.customProgramCacheKey = () => `vlf-rgbm-${range}`;
      m.needsUpdate = true;
    }
  });
}

// vlf's display mapping (vlf_core::image, shaders/common/display_mapping.wgsl): radiance ×
// 2^exposure, then clamp to [0, 1] or Narkowicz's ACES fit with its 0.6 pre-exposure; three.js
// then writes sRGB. Installed as three.js's CustomToneMapping.
export function useVlfToneMapping(renderer, tonemap, exposureStops) {
  const curve = tonemap === 'aces'
    ? `color = max(color, vec3(0.0)) * 0.6;
       return clamp((color * (2.51 * color + 0.03)) / (color * (2.43 * color + 0.59) + 0.14), 0.0, 1.0);`
    : 'return clamp(color, 0.0, 1.0);';
  THREE.ShaderChunk.tonemapping_pars_fragment = THREE.ShaderChunk.tonemapping_pars_fragment.replace(
    'vec3 CustomToneMapping( vec3 color ) { return color; }',
    `vec3 CustomToneMapping( vec3 color ) { color *= toneMappingExposure; ${curve} }`,
  );
  renderer.toneMapping = THREE.CustomToneMapping;
  renderer.toneMappingExposure = Math.pow(2, exposureStops);
  renderer.outputColorSpace = THREE.SRGBColorSpace;
}
