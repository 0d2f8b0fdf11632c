//! A glTF 2.0 binary (`.glb`) writer: one [`TriMesh`] as one mesh with one primitive and a
//! PBR material (metallic 0, roughness 1) whose textures are PNG bytes the caller encoded.
//!
//! Pure bytes: the same inputs give the same output, byte for byte. Layout: a 12-byte header,
//! a JSON chunk (padded with spaces to 4 bytes) and a BIN chunk (padded with zeros) holding,
//! each at a 4-byte aligned offset, positions, normals, texture coordinates, tangents, `u32`
//! indices and the images.
//!
//! glTF's texture coordinates have v down (the first image row at v = 0), so `(u, v)` is written
//! as `(u, 1 − v)`. Normals and tangents are written normalised (glTF requires unit vectors) and
//! a tangent's `w` as ±1.

use super::meshes::TriMesh;
use glam::{Vec2, Vec3, Vec4};
use serde_json::{json, Value};

/// PNG images for the material, each optional.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GlbTextures {
    /// sRGB base colour.
    pub base_color_png: Option<Vec<u8>>,
    /// Tangent-space normal map, +Y up in the image (increasing mesh v), as glTF expects.
    pub normal_png: Option<Vec<u8>>,
    /// Ambient occlusion in the red channel.
    pub occlusion_png: Option<Vec<u8>>,
    /// Grey height (0.5 = the surface), for parallax or displacement. glTF has no slot for it:
    /// the material's `extras.heightTexture` names it.
    pub height_png: Option<Vec<u8>>,
}

const GLB_MAGIC: u32 = 0x4654_6C67;
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;

/// The binary buffer under construction and its views.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
}

impl Bin {
    /// Appends `data` as a new buffer view (4-byte aligned); returns its index.
    fn view(&mut self, data: &[u8], target: Option<u32>) -> usize {
        while self.bytes.len() % 4 != 0 {
            self.bytes.push(0);
        }
        let mut v = json!({ "buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len() });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bytes.extend_from_slice(data);
        self.views.push(v);
        self.views.len() - 1
    }
}

fn floats(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

fn unit(v: Vec3, fallback: Vec3) -> Vec3 {
    v.try_normalize().unwrap_or(fallback)
}

/// Writes `mesh` (with optional glTF-convention per-vertex `tangents`: xyz and handedness `w`,
/// bitangent `w · cross(n, t)` along increasing mesh v) and its textures as a `.glb`.
///
/// Normals, texture coordinates and tangents are written when they have one entry per vertex
/// (tangents only with normals); textures only with texture coordinates. Tangents keep their
/// `w`: glTF's normal textures have +Y up in the image, which is increasing mesh v (decreasing
/// glTF v), so the frame whose bitangent follows mesh v is already the one glTF viewers use,
/// and normal maps need no green flip.
pub fn write_glb(mesh: &TriMesh, tangents: Option<&[Vec4]>, textures: &GlbTextures) -> Vec<u8> {
    let n = mesh.positions.len();
    let has_normals = n > 0 && mesh.normals.len() == n;
    let has_uvs = n > 0 && mesh.uvs.len() == n;
    let tangents = tangents.filter(|t| has_normals && t.len() == n);
    let mut bin = Bin::default();
    let mut accessors = Vec::new();
    let mut attributes = serde_json::Map::new();

    let (lo, hi) = mesh.bounds().unwrap_or((Vec3::ZERO, Vec3::ZERO));
    let view = bin.view(&floats(mesh.positions.iter().flat_map(|p| p.to_array())), Some(ARRAY_BUFFER));
    attributes.insert("POSITION".into(), json!(accessors.len()));
    accessors.push(json!({
        "bufferView": view, "componentType": FLOAT, "count": n, "type": "VEC3",
        "min": lo.to_array(), "max": hi.to_array(),
    }));
    if has_normals {
        let data = floats(mesh.normals.iter().flat_map(|&v| unit(v, Vec3::Z).to_array()));
        let view = bin.view(&data, Some(ARRAY_BUFFER));
        attributes.insert("NORMAL".into(), json!(accessors.len()));
        accessors.push(json!({ "bufferView": view, "componentType": FLOAT, "count": n, "type": "VEC3" }));
    }
    if let Some(tangents) = tangents {
        let data = floats(tangents.iter().zip(&mesh.normals).flat_map(|(t, &nrm)| {
            let nrm = unit(nrm, Vec3::Z);
            let xyz = unit(t.truncate(), nrm.any_orthonormal_vector());
            let w = if t.w < 0.0 { -1.0 } else { 1.0 };
            [xyz.x, xyz.y, xyz.z, w]
        }));
        let view = bin.view(&data, Some(ARRAY_BUFFER));
        attributes.insert("TANGENT".into(), json!(accessors.len()));
        accessors.push(json!({ "bufferView": view, "componentType": FLOAT, "count": n, "type": "VEC4" }));
    }
    if has_uvs {
        let data = floats(mesh.uvs.iter().flat_map(|&Vec2 { x, y }| [x, 1.0 - y]));
        let view = bin.view(&data, Some(ARRAY_BUFFER));
        attributes.insert("TEXCOORD_0".into(), json!(accessors.len()));
        accessors.push(json!({ "bufferView": view, "componentType": FLOAT, "count": n, "type": "VEC2" }));
    }
    let indices: Vec<u8> = mesh.triangles.iter().flat_map(|t| t.iter().flat_map(|i| i.to_le_bytes())).collect();
    let view = bin.view(&indices, Some(ELEMENT_ARRAY_BUFFER));
    let index_accessor = accessors.len();
    accessors.push(json!({
        "bufferView": view, "componentType": UNSIGNED_INT, "count": mesh.triangles.len() * 3, "type": "SCALAR",
    }));

    let mut images = Vec::new();
    let mut texture_of = |png: &Option<Vec<u8>>, bin: &mut Bin| -> Option<usize> {
        let png = png.as_ref().filter(|_| has_uvs)?;
        let view = bin.view(png, None);
        images.push(json!({ "bufferView": view, "mimeType": "image/png" }));
        Some(images.len() - 1)
    };
    let base = texture_of(&textures.base_color_png, &mut bin);
    let normal = texture_of(&textures.normal_png, &mut bin);
    let occlusion = texture_of(&textures.occlusion_png, &mut bin);
    let height = texture_of(&textures.height_png, &mut bin);
    while bin.bytes.len() % 4 != 0 {
        bin.bytes.push(0);
    }

    let mut pbr = json!({ "metallicFactor": 0.0, "roughnessFactor": 1.0 });
    if let Some(i) = base {
        pbr["baseColorTexture"] = json!({ "index": i });
    }
    let mut material = json!({ "name": "tessera", "pbrMetallicRoughness": pbr });
    if let Some(i) = normal {
        material["normalTexture"] = json!({ "index": i });
    }
    if let Some(i) = occlusion {
        material["occlusionTexture"] = json!({ "index": i });
    }
    if let Some(i) = height {
        material["extras"] = json!({ "heightTexture": { "index": i } });
    }
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": "tessera" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": attributes, "indices": index_accessor, "material": 0, "mode": 4 }] }],
        "materials": [material],
        "accessors": accessors,
        "bufferViews": bin.views,
        "buffers": [{ "byteLength": bin.bytes.len() }],
    });
    if !images.is_empty() {
        doc["textures"] = Value::Array((0..images.len()).map(|i| json!({ "source": i, "sampler": 0 })).collect());
        doc["images"] = Value::Array(images);
        // LINEAR, LINEAR_MIPMAP_LINEAR, REPEAT.
        doc["samplers"] = json!([{ "magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497 }]);
    }

    let mut json_bytes = serde_json::to_vec(&doc).expect("a JSON value serialises");
    while json_bytes.len() % 4 != 0 {
        json_bytes.push(b' ');
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.bytes.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&GLB_MAGIC.to_le_bytes());
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
    out.extend_from_slice(&json_bytes);
    out.extend_from_slice(&(bin.bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
    out.extend_from_slice(&bin.bytes);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u32_at(b: &[u8], at: usize) -> u32 {
        u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }

    /// Splits a `.glb` into its JSON document and BIN chunk, checking the framing.
    fn parse(glb: &[u8]) -> (Value, &[u8]) {
        assert_eq!(u32_at(glb, 0), GLB_MAGIC);
        assert_eq!(u32_at(glb, 4), 2);
        assert_eq!(u32_at(glb, 8) as usize, glb.len());
        let json_len = u32_at(glb, 12) as usize;
        assert_eq!(u32_at(glb, 16), CHUNK_JSON);
        assert_eq!(json_len % 4, 0);
        let doc: Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
        let at = 20 + json_len;
        let bin_len = u32_at(glb, at) as usize;
        assert_eq!(u32_at(glb, at + 4), CHUNK_BIN);
        assert_eq!(bin_len % 4, 0);
        assert_eq!(at + 8 + bin_len, glb.len());
        (doc, &glb[at + 8..])
    }

    fn square() -> TriMesh {
        TriMesh {
            positions: vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.2), Vec3::ZERO],
            normals: vec![Vec3::Z; 4],
            uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    #[test]
    fn header_chunks_and_accessors_are_consistent() {
        let mesh = square();
        let tangents = vec![Vec4::new(1.0, 0.0, 0.0, 1.0); 4];
        let textures = GlbTextures {
            base_color_png: Some(vec![1, 2, 3, 4, 5]),
            normal_png: Some(vec![6, 7, 8]),
            occlusion_png: None,
            height_png: Some(vec![9, 10]),
        };
        let glb = write_glb(&mesh, Some(&tangents), &textures);
        assert_eq!(glb, write_glb(&mesh, Some(&tangents), &textures), "deterministic");
        let (doc, bin) = parse(&glb);
        assert_eq!(doc["asset"]["version"], "2.0");
        assert_eq!(doc["asset"]["generator"], "tessera");
        assert_eq!(doc["buffers"][0]["byteLength"].as_u64().unwrap() as usize, bin.len());
        let prim = &doc["meshes"][0]["primitives"][0];
        let accessor = |name: &str| &doc["accessors"][prim["attributes"][name].as_u64().unwrap() as usize];
        for name in ["POSITION", "NORMAL", "TEXCOORD_0", "TANGENT"] {
            assert_eq!(accessor(name)["count"], 4, "{name}");
        }
        assert_eq!(accessor("POSITION")["max"], json!([1.0, 1.0, 0.2f32 as f64]));
        let indices = &doc["accessors"][prim["indices"].as_u64().unwrap() as usize];
        assert_eq!(indices["count"], 6);
        assert_eq!(indices["componentType"], UNSIGNED_INT);
        for view in doc["bufferViews"].as_array().unwrap() {
            let (off, len) =
                (view["byteOffset"].as_u64().unwrap() as usize, view["byteLength"].as_u64().unwrap() as usize);
            assert_eq!(off % 4, 0);
            assert!(off + len <= bin.len());
        }
        // The indices and texture coordinates (v flipped) read back.
        let iv = &doc["bufferViews"][indices["bufferView"].as_u64().unwrap() as usize];
        let off = iv["byteOffset"].as_u64().unwrap() as usize;
        let read: Vec<u32> = (0..6).map(|k| u32_at(bin, off + 4 * k)).collect();
        assert_eq!(read, vec![0, 1, 2, 0, 2, 3]);
        let tv = &doc["bufferViews"][accessor("TEXCOORD_0")["bufferView"].as_u64().unwrap() as usize];
        let off = tv["byteOffset"].as_u64().unwrap() as usize;
        assert_eq!(f32::from_bits(u32_at(bin, off + 4)), 1.0);
        // The images hold the bytes handed in.
        let image = &doc["images"][0];
        assert_eq!(image["mimeType"], "image/png");
        let v = &doc["bufferViews"][image["bufferView"].as_u64().unwrap() as usize];
        let off = v["byteOffset"].as_u64().unwrap() as usize;
        assert_eq!(&bin[off..off + 5], &[1, 2, 3, 4, 5]);
        let material = &doc["materials"][0];
        assert_eq!(material["pbrMetallicRoughness"]["metallicFactor"], 0.0);
        assert_eq!(material["pbrMetallicRoughness"]["roughnessFactor"], 1.0);
        assert_eq!(material["normalTexture"]["index"], 1);
        assert_eq!(material["extras"]["heightTexture"]["index"], 2);
        assert_eq!(doc["textures"].as_array().unwrap().len(), 3);
        assert_eq!(doc["samplers"][0]["wrapS"], 10497);
    }

    #[test]
    fn a_bare_mesh_has_no_textures() {
        let mesh = TriMesh { normals: Vec::new(), uvs: Vec::new(), ..square() };
        let glb = write_glb(&mesh, None, &GlbTextures { base_color_png: Some(vec![0; 7]), ..Default::default() });
        let (doc, _) = parse(&glb);
        let attrs = doc["meshes"][0]["primitives"][0]["attributes"].as_object().unwrap();
        assert_eq!(attrs.keys().collect::<Vec<_>>(), vec!["POSITION"]);
        assert!(doc.get("images").is_none());
    }
}
