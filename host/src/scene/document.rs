//! The glTF document: GLB container, JSON, validation, buffers, URIs and accessors, each checked
//! before use so that no input panics (the `gltf` crate's own readers and GLB parser can).

use base64::Engine;
use glam::{Vec2, Vec3};
use gltf::json::{
    self,
    accessor::{ComponentType, Type},
    validation::{Checked, Error as ValidationError, Validate},
};
use std::collections::HashMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use super::Warning;
use crate::{Error, Result};

/// Extensions the loader understands, so a file may require them.
pub(super) const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_mesh_quantization",
    "KHR_texture_basisu",
    "MSFT_texture_dds",
];

/// Largest accessor the loader reads, in bytes as stored: bounds what an accessor without a buffer
/// view (all zeros, or sparse), whose size no data limits, can make it allocate.
const MAX_ACCESSOR_BYTES: u64 = 1 << 28;

/// The file being loaded, and what the loader has to say about it.
pub(super) struct Ctx {
    /// The scene file.
    pub file: PathBuf,
    /// Where relative URIs start.
    dir: PathBuf,
    warnings: Vec<Warning>,
    /// Warning kind -> its index in `warnings`.
    kinds: HashMap<String, usize>,
}

impl Ctx {
    pub fn new(file: &Path) -> Self {
        Self {
            file: file.to_owned(),
            dir: file.parent().map(Path::to_owned).unwrap_or_default(),
            warnings: Vec::new(),
            kinds: HashMap::new(),
        }
    }

    /// An [`Error::Scene`] about `element` of this file.
    pub fn error(&self, element: impl Into<String>, why: impl Into<String>) -> Error {
        Error::Scene {
            file: self.file.clone(),
            element: element.into(),
            why: why.into(),
        }
    }

    /// Records `count` occurrences of warning `kind`; the first occurrence names the element and
    /// gives the message.
    pub fn warn(
        &mut self,
        kind: &str,
        element: impl Into<String>,
        message: impl Into<String>,
        count: usize,
    ) {
        match self.kinds.get(kind) {
            Some(&i) => self.warnings[i].count += count,
            None => {
                self.kinds.insert(kind.to_owned(), self.warnings.len());
                self.warnings.push(Warning {
                    file: self.file.clone(),
                    element: element.into(),
                    message: message.into(),
                    count,
                });
            }
        }
    }

    pub fn warnings(&self) -> &[Warning] {
        &self.warnings
    }

    pub fn into_warnings(self) -> Vec<Warning> {
        self.warnings
    }

    /// The bytes a URI names, at most `at_most` of them: a base64 `data:` URI (all of it), or a
    /// path relative to the scene file, which must be a regular file (a device such as
    /// `/dev/zero`, or a pipe, may never end). The error says why, naming the file it tried.
    pub fn read_uri(&self, uri: &str, at_most: u64) -> std::result::Result<Vec<u8>, String> {
        if let Some(data) = uri.strip_prefix("data:") {
            let Some((header, payload)) = data.split_once(',') else {
                return Err("data URI without a ',' before its payload".to_owned());
            };
            if !header.ends_with(";base64") {
                return Err(format!("data URI {header:?} is not base64-encoded"));
            }
            return base64::engine::general_purpose::STANDARD
                .decode(payload.trim_end())
                .map_err(|e| format!("data URI is not valid base64: {e}"));
        }
        if uri.contains("://") {
            return Err(format!(
                "URI {uri:?} is not supported: only relative paths and data: URIs are"
            ));
        }
        let path = self.dir.join(percent_decode(uri));
        let cannot_read = |e: std::io::Error| format!("cannot read {}: {e}", path.display());
        let file = std::fs::File::open(&path).map_err(cannot_read)?;
        if !file.metadata().map_err(cannot_read)?.is_file() {
            return Err(format!("{} is not a regular file", path.display()));
        }
        let mut data = Vec::new();
        file.take(at_most)
            .read_to_end(&mut data)
            .map_err(cannot_read)?;
        Ok(data)
    }
}

/// `name` of glTF array `array` at `index` as the loader names elements: `meshes[2] ("Box")`.
pub(super) fn label(array: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(name) => format!("{array}[{index}] ({name:?})"),
        None => format!("{array}[{index}]"),
    }
}

/// Decodes `%XX` escapes of a URI path; anything else stays as it is.
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes
            .get(i + 1..i + 3)
            .and_then(|h| std::str::from_utf8(h).ok())
            .and_then(|h| u8::from_str_radix(h, 16).ok());
        match (bytes[i], hex) {
            (b'%', Some(byte)) => {
                out.push(byte);
                i += 3;
            }
            (byte, _) => {
                out.push(byte);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// A parsed, validated glTF document with its buffers.
pub(super) struct Document {
    pub root: json::Root,
    buffers: Vec<Vec<u8>>,
}

impl Document {
    /// Parses a `.gltf` or `.glb` file's bytes, validates the document and loads its buffers.
    pub fn parse(ctx: &mut Ctx, bytes: &[u8]) -> Result<Self> {
        let (json_bytes, bin) = if bytes.starts_with(b"glTF") {
            split_glb(bytes).map_err(|why| ctx.error("GLB container", why))?
        } else {
            (bytes, None)
        };
        // The specification lets readers skip a UTF-8 byte order mark; serde does not.
        let json_bytes = json_bytes
            .strip_prefix(b"\xEF\xBB\xBF")
            .unwrap_or(json_bytes);
        let root = json::Root::from_slice(json_bytes)
            .map_err(|e| ctx.error("JSON", format!("malformed glTF JSON: {e}")))?;
        // A new major version may change what any field means: refuse it rather than guess.
        let version = &root.asset.version;
        if version.split('.').next() != Some("2") {
            return Err(ctx.error(
                "asset.version",
                format!("glTF {version:?} is not supported: only glTF 2.x is"),
            ));
        }
        for (i, ext) in root.extensions_required.iter().enumerate() {
            if !SUPPORTED_EXTENSIONS.contains(&ext.as_str()) {
                return Err(ctx.error(
                    format!("extensionsRequired[{i}]"),
                    format!(
                        "required extension {ext} is not supported (supported: {})",
                        SUPPORTED_EXTENSIONS.join(", ")
                    ),
                ));
            }
        }
        for (i, ext) in root.extensions_used.iter().enumerate() {
            if !SUPPORTED_EXTENSIONS.contains(&ext.as_str()) {
                ctx.warn(
                    &format!("extension {ext}"),
                    format!("extensionsUsed[{i}]"),
                    format!("extension {ext} is not supported: what it adds is ignored"),
                    1,
                );
            }
        }
        validate(ctx, &root)?;
        let buffers = load_buffers(ctx, &root, bin)?;
        Ok(Self { root, buffers })
    }

    /// The bytes of buffer view `index`.
    pub fn view(&self, ctx: &Ctx, index: usize) -> Result<&[u8]> {
        let element = format!("bufferViews[{index}]");
        let view = self
            .root
            .buffer_views
            .get(index)
            .ok_or_else(|| ctx.error(&element, "does not exist"))?;
        let buffer_index = view.buffer.value();
        let buffer = self.buffers.get(buffer_index).ok_or_else(|| {
            ctx.error(&element, format!("buffers[{buffer_index}] does not exist"))
        })?;
        let start = view.byte_offset.map_or(0, |o| o.0);
        let end = start.checked_add(view.byte_length.0);
        end.and_then(|end| buffer.get(usize::try_from(start).ok()?..usize::try_from(end).ok()?))
            .ok_or_else(|| {
                ctx.error(
                    &element,
                    format!(
                        "bytes {start}..{} lie outside buffers[{buffer_index}], which has {} bytes",
                        start.saturating_add(view.byte_length.0),
                        buffer.len()
                    ),
                )
            })
    }

    /// Number of elements of accessor `index`.
    pub fn accessor_count(&self, index: usize) -> usize {
        self.root
            .accessors
            .get(index)
            .map_or(0, |a| usize::try_from(a.count.0).unwrap_or(usize::MAX))
    }

    /// Accessor `index` as `VEC3` floats (any component type, normalised ones scaled to [0, 1] or
    /// [-1, 1] as `KHR_mesh_quantization` allows); `usage` names what reads it, for errors.
    pub fn read_vec3(&self, ctx: &Ctx, index: usize, usage: &str) -> Result<Vec<Vec3>> {
        let values = self.read::<f32>(ctx, index, usage, Type::Vec3, component_f32)?;
        Ok(values
            .as_chunks::<3>()
            .0
            .iter()
            .map(|&v| Vec3::from_array(v))
            .collect())
    }

    /// Accessor `index` as `VEC2` floats, like [`Document::read_vec3`].
    pub fn read_vec2(&self, ctx: &Ctx, index: usize, usage: &str) -> Result<Vec<Vec2>> {
        let values = self.read::<f32>(ctx, index, usage, Type::Vec2, component_f32)?;
        Ok(values
            .as_chunks::<2>()
            .0
            .iter()
            .map(|&v| Vec2::from_array(v))
            .collect())
    }

    /// Accessor `index` of type `ty` as floats, its components flattened, converted like
    /// [`Document::read_vec3`].
    pub fn read_floats(&self, ctx: &Ctx, index: usize, usage: &str, ty: Type) -> Result<Vec<f32>> {
        self.read::<f32>(ctx, index, usage, ty, component_f32)
    }

    /// Accessor `index` as vertex indices: `SCALAR` of unsigned bytes, shorts or ints.
    pub fn read_indices(&self, ctx: &Ctx, index: usize, usage: &str) -> Result<Vec<u32>> {
        let element = accessor_element(index, usage);
        match self.root.accessors.get(index).map(|a| &a.component_type) {
            Some(Checked::Valid(json::accessor::GenericComponentType(
                ComponentType::U8 | ComponentType::U16 | ComponentType::U32,
            ))) => {}
            Some(Checked::Valid(json::accessor::GenericComponentType(other))) => {
                return Err(ctx.error(
                    element,
                    format!("index accessors hold unsigned integers, not {other:?}"),
                ));
            }
            _ => return Err(ctx.error(element, "does not exist or has no valid componentType")),
        }
        self.read::<u32>(ctx, index, usage, Type::Scalar, |ty, _, bytes| {
            read_uint(ty, bytes)
        })
    }

    /// Reads accessor `index` of type `ty`, converting each component with `convert`, with every
    /// offset checked against its buffer view, sparse substitution included.
    fn read<T: Copy>(
        &self,
        ctx: &Ctx,
        index: usize,
        usage: &str,
        ty: Type,
        convert: impl Fn(ComponentType, bool, &[u8]) -> T,
    ) -> Result<Vec<T>> {
        let element = accessor_element(index, usage);
        let accessor = self
            .root
            .accessors
            .get(index)
            .ok_or_else(|| ctx.error(&element, "does not exist"))?;
        match accessor.type_ {
            Checked::Valid(t) if t == ty => {}
            Checked::Valid(t) => {
                return Err(ctx.error(&element, format!("has type {t:?}, expected {ty:?}")));
            }
            Checked::Invalid => return Err(ctx.error(&element, "has an invalid type")),
        }
        let Checked::Valid(json::accessor::GenericComponentType(component)) =
            accessor.component_type
        else {
            return Err(ctx.error(&element, "has an invalid componentType"));
        };
        let size = component.size();
        let components = ty.multiplicity();
        let elem = size * components;
        let count = accessor.count.0;
        if count.saturating_mul(elem as u64) > MAX_ACCESSOR_BYTES {
            return Err(ctx.error(&element, format!("count {count} is too large")));
        }
        let count = count as usize;
        let normalized = accessor.normalized;
        let zero = [0u8; 4];
        let mut out = match accessor.buffer_view {
            Some(view_index) => {
                let bytes = self.view(ctx, view_index.value())?;
                let stride = self.root.buffer_views[view_index.value()]
                    .byte_stride
                    .map_or(elem, |s| s.0);
                if stride < elem {
                    return Err(ctx.error(
                        &element,
                        format!(
                            "bufferViews[{}] has byteStride {stride}, less than its {elem}-byte \
                             elements: they would overlap",
                            view_index.value()
                        ),
                    ));
                }
                let offset = accessor.byte_offset.map_or(0, |o| o.0 as usize);
                if count > 0 {
                    let end = stride
                        .checked_mul(count - 1)
                        .and_then(|s| s.checked_add(offset))
                        .and_then(|s| s.checked_add(elem));
                    if end.is_none_or(|end| end > bytes.len()) {
                        return Err(ctx.error(
                            &element,
                            format!(
                                "{count} elements of {elem} bytes from byte {offset} with stride \
                                 {stride} do not fit in bufferViews[{}], which has {} bytes",
                                view_index.value(),
                                bytes.len()
                            ),
                        ));
                    }
                }
                let mut out = Vec::with_capacity(count * components);
                for i in 0..count {
                    let base = offset + i * stride;
                    for c in 0..components {
                        let at = base + c * size;
                        out.push(convert(component, normalized, &bytes[at..at + size]));
                    }
                }
                out
            }
            None => vec![convert(component, normalized, &zero[..size]); count * components],
        };
        if let Some(sparse) = &accessor.sparse {
            let n = sparse.count.0 as usize;
            let sparse_element = format!("{element}.sparse");
            let Checked::Valid(json::accessor::IndexComponentType(index_type)) =
                sparse.indices.component_type
            else {
                return Err(ctx.error(&sparse_element, "has an invalid index componentType"));
            };
            let index_size = index_type.size();
            let indices = tail(
                self.view(ctx, sparse.indices.buffer_view.value())?,
                sparse.indices.byte_offset.0,
                n.saturating_mul(index_size),
            )
            .ok_or_else(|| ctx.error(&sparse_element, "indices lie outside their buffer view"))?;
            let values = tail(
                self.view(ctx, sparse.values.buffer_view.value())?,
                sparse.values.byte_offset.0,
                n.saturating_mul(elem),
            )
            .ok_or_else(|| ctx.error(&sparse_element, "values lie outside their buffer view"))?;
            for k in 0..n {
                let target =
                    read_uint(index_type, &indices[k * index_size..(k + 1) * index_size]) as usize;
                if target >= count {
                    return Err(ctx.error(
                        &sparse_element,
                        format!(
                            "index {target} is out of range: the accessor has {count} elements"
                        ),
                    ));
                }
                for c in 0..components {
                    let at = k * elem + c * size;
                    out[target * components + c] =
                        convert(component, normalized, &values[at..at + size]);
                }
            }
        }
        Ok(out)
    }
}

fn accessor_element(index: usize, usage: &str) -> String {
    format!("accessors[{index}] ({usage})")
}

/// `len` bytes of `bytes` from `offset`, if they are there.
fn tail(bytes: &[u8], offset: u64, len: usize) -> Option<&[u8]> {
    let start = usize::try_from(offset).ok()?;
    bytes.get(start..start.checked_add(len)?)
}

/// A little-endian unsigned integer of type `ty` (`bytes` holds exactly one).
fn read_uint(ty: ComponentType, bytes: &[u8]) -> u32 {
    match (ty, bytes) {
        (ComponentType::U8 | ComponentType::I8, [b]) => u32::from(*b),
        (ComponentType::U16 | ComponentType::I16, [a, b]) => {
            u32::from(u16::from_le_bytes([*a, *b]))
        }
        (_, [a, b, c, d]) => u32::from_le_bytes([*a, *b, *c, *d]),
        _ => 0,
    }
}

/// One component as `f32`, normalised integers mapped as the glTF specification says.
fn component_f32(ty: ComponentType, normalized: bool, bytes: &[u8]) -> f32 {
    match (ty, bytes) {
        (ComponentType::F32, [a, b, c, d]) => f32::from_le_bytes([*a, *b, *c, *d]),
        (ComponentType::U8, [b]) if normalized => f32::from(*b) / 255.0,
        (ComponentType::U8, [b]) => f32::from(*b),
        (ComponentType::I8, [b]) if normalized => (f32::from(*b as i8) / 127.0).max(-1.0),
        (ComponentType::I8, [b]) => f32::from(*b as i8),
        (ComponentType::U16, [a, b]) if normalized => {
            f32::from(u16::from_le_bytes([*a, *b])) / 65535.0
        }
        (ComponentType::U16, [a, b]) => f32::from(u16::from_le_bytes([*a, *b])),
        (ComponentType::I16, [a, b]) if normalized => {
            (f32::from(i16::from_le_bytes([*a, *b])) / 32767.0).max(-1.0)
        }
        (ComponentType::I16, [a, b]) => f32::from(i16::from_le_bytes([*a, *b])),
        (ComponentType::U32, [a, b, c, d]) => u32::from_le_bytes([*a, *b, *c, *d]) as f32,
        _ => 0.0,
    }
}

/// Splits a GLB file into its JSON chunk and its optional BIN chunk.
fn split_glb(bytes: &[u8]) -> std::result::Result<(&[u8], Option<&[u8]>), String> {
    let word = |at: usize| -> Option<u32> {
        let b: [u8; 4] = bytes.get(at..at.checked_add(4)?)?.try_into().ok()?;
        Some(u32::from_le_bytes(b))
    };
    let version = word(4).ok_or("shorter than its 12-byte header")?;
    if version != 2 {
        return Err(format!("GLB version {version}, expected 2"));
    }
    let length = word(8).ok_or("shorter than its 12-byte header")? as usize;
    if length > bytes.len() {
        return Err(format!(
            "header says {length} bytes, the file has {}",
            bytes.len()
        ));
    }
    let mut json = None;
    let mut bin = None;
    let mut at = 12;
    while at < length {
        let (Some(chunk_length), Some(kind)) = (word(at), bytes.get(at + 4..at + 8)) else {
            return Err(format!("chunk header at byte {at} is cut off"));
        };
        let start = at + 8;
        let end = start
            .checked_add(chunk_length as usize)
            .filter(|&end| end <= length)
            .ok_or_else(|| {
                format!("chunk at byte {at} ({chunk_length} bytes) runs past the end")
            })?;
        let chunk = &bytes[start..end];
        match (kind, json.is_some()) {
            (b"JSON", false) => json = Some(chunk),
            (b"BIN\0", true) if bin.is_none() => bin = Some(chunk),
            (b"JSON", true) | (b"BIN\0", _) => {
                return Err(format!(
                    "unexpected chunk {:?} at byte {at}",
                    String::from_utf8_lossy(kind)
                ));
            }
            // The specification says to skip chunks of unknown types.
            _ => {}
        }
        // Chunks start on 4-byte boundaries.
        at = end.next_multiple_of(4);
    }
    let json = json.ok_or("no JSON chunk")?;
    Ok((json, bin))
}

/// Runs the glTF validation of the `gltf` crate: a failure is an error naming its path, except
/// missing `min`/`max` bounds (unused here: a warning) and unsupported extensions (checked before,
/// against [`SUPPORTED_EXTENSIONS`]).
fn validate(ctx: &mut Ctx, root: &json::Root) -> Result<()> {
    // The crate's validation indexes the POSITION accessor without a bounds check: check first.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = Checked::Valid(json::mesh::Semantic::Positions);
            if let Some(accessor) = primitive.attributes.get(&position)
                && accessor.value() >= root.accessors.len()
            {
                return Err(ctx.error(
                    format!("meshes[{m}].primitives[{p}].attributes[\"POSITION\"]"),
                    "refers to an element that does not exist",
                ));
            }
        }
    }
    let mut errors = Vec::new();
    root.validate(root, json::Path::new, &mut |path, error| {
        errors.push((json_path(path().to_string()), error))
    });
    let mut fatal = Vec::new();
    for (path, error) in errors {
        match error {
            ValidationError::Unsupported => {}
            // The animation parser checks every index and value it uses and drops the channels it
            // cannot play, naming them: a broken animation costs its channels, not the scene.
            _ if path.starts_with("animations") => ctx.warn(
                "animation validation",
                path,
                "invalid animation data: channels that use it are dropped",
                1,
            ),
            _ if path.ends_with(".min") || path.ends_with(".max") => ctx.warn(
                "accessor bounds",
                path,
                "POSITION accessor lacks valid min/max: bounds are computed from the vertices",
                1,
            ),
            _ => fatal.push((path, error)),
        }
    }
    let Some((path, error)) = fatal.first() else {
        return Ok(());
    };
    let what = match error {
        ValidationError::IndexOutOfBounds => "refers to an element that does not exist",
        ValidationError::Invalid => "has an invalid value",
        ValidationError::Missing => "is required but missing",
        ValidationError::Oversize => "exceeds the size limits",
        ValidationError::Unsupported => "is not supported",
    };
    let more = match fatal.len() {
        1 => String::new(),
        n => format!(" ({} more validation errors)", n - 1),
    };
    Err(ctx.error(path.clone(), format!("{what}{more}")))
}

/// A validation path as the file spells it: the `gltf` crate names `KHR_lights_punctual` (the
/// only extension it validates references of) by its Rust field, `khrLightsPunctual`.
fn json_path(path: String) -> String {
    path.replace("khrLightsPunctual", "KHR_lights_punctual")
}

/// Loads every buffer: the GLB BIN chunk, `data:` URIs or files next to the scene file.
fn load_buffers(ctx: &Ctx, root: &json::Root, bin: Option<&[u8]>) -> Result<Vec<Vec<u8>>> {
    root.buffers
        .iter()
        .enumerate()
        .map(|(i, buffer)| {
            let element = label("buffers", i, buffer.name.as_deref());
            let mut data = match (&buffer.uri, bin) {
                // A longer file is fine: bytes past byteLength are never read.
                (Some(uri), _) => ctx.read_uri(uri, buffer.byte_length.0).map_err(|why| {
                    // A data URI can be megabytes of base64: name it, do not quote it.
                    let source = match uri.starts_with("data:") {
                        true => "(data URI)".to_owned(),
                        false => format!("(uri {uri:?})"),
                    };
                    ctx.error(format!("{element} {source}"), why)
                })?,
                (None, Some(bin)) if i == 0 => bin.to_vec(),
                (None, _) => {
                    return Err(ctx.error(element, "has no uri and is not the GLB BIN chunk"));
                }
            };
            let length = buffer.byte_length.0;
            if (data.len() as u64) < length {
                return Err(ctx.error(
                    element,
                    format!(
                        "holds {} bytes, fewer than its byteLength {length}",
                        data.len()
                    ),
                ));
            }
            // Reads past byteLength are errors even where the data (a padded BIN chunk) goes on.
            data.truncate(length as usize);
            Ok(data)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b%2Fc.png"), "a b/c.png");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("%zz%4"), "%zz%4");
    }

    #[test]
    fn glb_split_rejects_short_and_lying_headers() {
        assert!(split_glb(b"glTF").is_err());
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(5u32.to_le_bytes()); // shorter than the header itself
        assert!(split_glb(&glb).is_err());
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(1000u32.to_le_bytes());
        assert!(split_glb(&glb).is_err());
    }

    #[test]
    fn glb_split_finds_chunks() {
        let json = b"{}  ";
        let bin = [1u8, 2, 3, 4];
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend((12 + 8 + 4 + 8 + 4u32).to_le_bytes());
        glb.extend(4u32.to_le_bytes());
        glb.extend(b"JSON");
        glb.extend(json);
        glb.extend(4u32.to_le_bytes());
        glb.extend(b"BIN\0");
        glb.extend(bin);
        let (j, b) = split_glb(&glb).unwrap();
        assert_eq!(j, json);
        assert_eq!(b, Some(&bin[..]));
        // A chunk length past the end is an error, not a panic.
        glb[12] = 200;
        assert!(split_glb(&glb).is_err());
    }

    #[test]
    fn normalised_components() {
        assert_eq!(component_f32(ComponentType::U8, true, &[255]), 1.0);
        assert_eq!(component_f32(ComponentType::I8, true, &[0x80]), -1.0);
        assert_eq!(
            component_f32(ComponentType::I16, true, &(-32767i16).to_le_bytes()),
            -1.0
        );
        assert_eq!(
            component_f32(ComponentType::U16, false, &7u16.to_le_bytes()),
            7.0
        );
        assert_eq!(read_uint(ComponentType::U16, &513u16.to_le_bytes()), 513);
    }
}
