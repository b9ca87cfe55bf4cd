//! Texture files -> RGBA8 mip chains: PNG and JPEG (the `image` crate), KTX2 (`ktx2`) and DDS
//! (`ddsfile`), recognised by their content.
//!
//! KTX2 and DDS texels may be uncompressed 8-bit (RGBA, BGRA, RGB, BGR, R, RG, and the X8
//! variants) or block-compressed BC1–BC7, decoded by `bcdec_rs` (a safe, pure-Rust port of
//! bcdec, a widely used single-file decoder checked against the Direct3D reference; no C, no
//! `unsafe`). KTX2 levels may be Zstandard-supercompressed (`ruzstd`); Basis Universal payloads
//! (BasisLZ/ETC1S, UASTC) are refused. Only 2D textures are read: arrays, cube maps and volumes
//! are refused, and signed (SNORM) formats too.
//!
//! Channels: one-channel formats (R8, L8, BC4) become grey (R copied to G and B), two-channel ones
//! (R8G8, BC5) become (R, G, 0); alpha is opaque where the format has none, including BC1 when
//! the KTX2 format says `RGB` (its transparent-black texel is then black). BC6H is HDR: its linear
//! texels are clamped to [0, 1], then encoded like the other texels (see below), and the caller is
//! told.
//!
//! # sRGB or linear
//!
//! glTF says how the texels of a slot are encoded (base colour and emissive textures are sRGB),
//! and files often disagree with their own format (a DDS `UNORM` format holding sRGB colour is
//! common). So the bytes are kept as stored and taken as the slot says, whether the file's format
//! says `UNORM` or `SRGB`. Only BC6H, whose texels are linear floats, is encoded for the slot:
//! through the sRGB transfer function for an sRGB slot.
//!
//! # Levels
//!
//! A file's own levels are kept when it has the complete chain down to 1×1; otherwise its first
//! level is kept and the chain generated ([`mip_chain`]).

use gi_shared::color::linear_to_srgb;
use rayon::prelude::*;
use std::io::Read;

use super::mip_chain::{level_count, level_size, mip_chain};

/// A decoded texture: its size and complete RGBA8 mip chain.
#[derive(Debug)]
pub struct Decoded {
    /// Width of level 0 in texels.
    pub width: u32,
    /// Height of level 0 in texels.
    pub height: u32,
    /// Level 0 first, down to 1×1.
    pub levels: Vec<Vec<u8>>,
    /// Something the caller should pass on as a warning (texels changed on decoding).
    pub note: Option<&'static str>,
}

const KTX2_MAGIC: [u8; 12] = [
    0xAB, b'K', b'T', b'X', b' ', b'2', b'0', 0xBB, b'\r', b'\n', 0x1A, b'\n',
];

/// Largest side accepted: bounds what a corrupt header can make the decoder allocate.
const MAX_SIDE: u32 = 16_384;

/// Decodes a texture file (PNG, JPEG, KTX2 or DDS) whose colour channels are sRGB-encoded if
/// `srgb`; the error says why it cannot be used.
pub fn decode(bytes: &[u8], srgb: bool) -> Result<Decoded, String> {
    let (width, height, levels, note) = if bytes.starts_with(&KTX2_MAGIC) {
        ktx2_levels(bytes, srgb).map_err(|e| format!("KTX2: {e}"))?
    } else if bytes.starts_with(b"DDS ") {
        dds_levels(bytes, srgb).map_err(|e| format!("DDS: {e}"))?
    } else {
        let image = image::load_from_memory(bytes).map_err(|e| format!("cannot decode it: {e}"))?;
        let rgba = image.into_rgba8();
        (rgba.width(), rgba.height(), vec![rgba.into_raw()], None)
    };
    let levels = match levels.len() == level_count(width, height) {
        true => levels,
        false => {
            let level0 = levels.into_iter().next().unwrap_or_default();
            mip_chain(level0, width, height, srgb)
        }
    };
    Ok(Decoded {
        width,
        height,
        levels,
        note,
    })
}

type Levels = (u32, u32, Vec<Vec<u8>>, Option<&'static str>);

/// How a file stores its texels.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Encoding {
    /// One texel after another.
    Texels(Texel),
    /// 4×4 blocks, row by row; partial blocks at the right and bottom edges.
    Blocks(Block),
}

/// An uncompressed 8-bit texel layout.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Texel {
    Rgba8,
    Bgra8,
    /// RGBA with an unused fourth byte.
    Rgbx8,
    Bgrx8,
    Rgb8,
    Bgr8,
    R8,
    Rg8,
}

/// A block-compressed format.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Block {
    /// BC1 with its 1-bit alpha, or (`alpha: false`) opaque.
    Bc1 {
        alpha: bool,
    },
    Bc2,
    Bc3,
    Bc4,
    Bc5,
    Bc6h {
        signed: bool,
    },
    Bc7,
}

impl Encoding {
    /// Bytes of a `width × height` level.
    fn level_bytes(self, width: u32, height: u32) -> u64 {
        let (w, h) = (u64::from(width), u64::from(height));
        match self {
            Self::Texels(t) => w * h * t.bytes() as u64,
            Self::Blocks(b) => w.div_ceil(4) * h.div_ceil(4) * b.bytes() as u64,
        }
    }
}

impl Texel {
    fn bytes(self) -> usize {
        match self {
            Self::R8 => 1,
            Self::Rg8 => 2,
            Self::Rgb8 | Self::Bgr8 => 3,
            Self::Rgba8 | Self::Bgra8 | Self::Rgbx8 | Self::Bgrx8 => 4,
        }
    }

    fn rgba(self, t: &[u8]) -> [u8; 4] {
        match self {
            Self::Rgba8 => [t[0], t[1], t[2], t[3]],
            Self::Bgra8 => [t[2], t[1], t[0], t[3]],
            Self::Rgbx8 | Self::Rgb8 => [t[0], t[1], t[2], 255],
            Self::Bgrx8 | Self::Bgr8 => [t[2], t[1], t[0], 255],
            Self::R8 => [t[0], t[0], t[0], 255],
            Self::Rg8 => [t[0], t[1], 0, 255],
        }
    }
}

impl Block {
    fn bytes(self) -> usize {
        match self {
            Self::Bc1 { .. } | Self::Bc4 => 8,
            Self::Bc2 | Self::Bc3 | Self::Bc5 | Self::Bc6h { .. } | Self::Bc7 => 16,
        }
    }
}

fn ktx2_encoding(format: Option<ktx2::Format>) -> Result<Encoding, String> {
    use ktx2::Format as F;
    let Some(format) = format else {
        return Err("format UNDEFINED (a Basis Universal payload) is not supported".to_owned());
    };
    Ok(match format {
        F::R8G8B8A8_UNORM | F::R8G8B8A8_SRGB => Encoding::Texels(Texel::Rgba8),
        F::B8G8R8A8_UNORM | F::B8G8R8A8_SRGB => Encoding::Texels(Texel::Bgra8),
        F::R8G8B8_UNORM | F::R8G8B8_SRGB => Encoding::Texels(Texel::Rgb8),
        F::B8G8R8_UNORM | F::B8G8R8_SRGB => Encoding::Texels(Texel::Bgr8),
        F::R8_UNORM | F::R8_SRGB => Encoding::Texels(Texel::R8),
        F::R8G8_UNORM | F::R8G8_SRGB => Encoding::Texels(Texel::Rg8),
        F::BC1_RGB_UNORM_BLOCK | F::BC1_RGB_SRGB_BLOCK => {
            Encoding::Blocks(Block::Bc1 { alpha: false })
        }
        F::BC1_RGBA_UNORM_BLOCK | F::BC1_RGBA_SRGB_BLOCK => {
            Encoding::Blocks(Block::Bc1 { alpha: true })
        }
        F::BC2_UNORM_BLOCK | F::BC2_SRGB_BLOCK => Encoding::Blocks(Block::Bc2),
        F::BC3_UNORM_BLOCK | F::BC3_SRGB_BLOCK => Encoding::Blocks(Block::Bc3),
        F::BC4_UNORM_BLOCK => Encoding::Blocks(Block::Bc4),
        F::BC5_UNORM_BLOCK => Encoding::Blocks(Block::Bc5),
        F::BC6H_UFLOAT_BLOCK => Encoding::Blocks(Block::Bc6h { signed: false }),
        F::BC6H_SFLOAT_BLOCK => Encoding::Blocks(Block::Bc6h { signed: true }),
        F::BC7_UNORM_BLOCK | F::BC7_SRGB_BLOCK => Encoding::Blocks(Block::Bc7),
        other => return Err(format!("format {other:?} is not supported")),
    })
}

fn ktx2_levels(bytes: &[u8], srgb: bool) -> Result<Levels, String> {
    use ktx2::SupercompressionScheme as S;
    check_dfd(bytes)?;
    let reader = ktx2::Reader::new(bytes).map_err(|e| format!("not a valid file: {e:?}"))?;
    let header = reader.header();
    if header.pixel_depth > 1 || header.layer_count > 1 || header.face_count != 1 {
        return Err("only 2D textures are supported, not arrays, cube maps or volumes".to_owned());
    }
    let (width, height) = (header.pixel_width, header.pixel_height.max(1));
    check_size(width, height)?;
    let zstd = match header.supercompression_scheme {
        None => false,
        Some(S::Zstandard) => true,
        Some(S::BasisLZ) => {
            return Err(
                "Basis Universal (BasisLZ) supercompression is not supported: it needs a \
                 transcoder"
                    .to_owned(),
            );
        }
        Some(other) => return Err(format!("supercompression {other:?} is not supported")),
    };
    let encoding = ktx2_encoding(header.format)?;
    let levels = reader
        .levels()
        .take(level_count(width, height))
        .enumerate()
        .map(|(l, level)| {
            let (w, h) = (level_size(width, l), level_size(height, l));
            let expected = encoding.level_bytes(w, h);
            let data = match zstd {
                true => {
                    inflate_zstd(level.data, expected).map_err(|e| format!("level {l}: {e}"))?
                }
                false => level.data.to_vec(),
            };
            let data = exact(&data, expected).map_err(|e| format!("level {l}: {e}"))?;
            Ok(decode_level(encoding, data, w, h, srgb))
        })
        .collect::<Result<Vec<_>, String>>()?;
    Ok((width, height, levels, note(encoding)))
}

/// Refuses what `ktx2` 0.5 would panic on: a basic data format descriptor block whose texel
/// block dimension byte is 255 (its `dimension + 1` overflows).
fn check_dfd(bytes: &[u8]) -> Result<(), String> {
    let u32_at = |at: usize| {
        let b = bytes.get(at..at.checked_add(4)?)?;
        Some(u32::from_le_bytes(b.try_into().ok()?) as usize)
    };
    let (Some(offset), Some(length)) = (u32_at(48), u32_at(52)) else {
        return Ok(());
    };
    // The descriptor starts with its total size; blocks follow, each with an 8-byte header.
    let (mut at, end) = (offset.saturating_add(4), offset.saturating_add(length));
    while at.saturating_add(16) <= end {
        let Some(block) = bytes.get(at..at + 16) else {
            break;
        };
        let basic = block[..4] == [0, 0, 0, 0];
        if basic && block[12..16].contains(&255) {
            return Err("not a valid file: a texel block dimension of 256".to_owned());
        }
        let size = usize::from(u16::from_le_bytes([block[6], block[7]]));
        if size == 0 {
            break;
        }
        at += size;
    }
    Ok(())
}

fn inflate_zstd(data: &[u8], expected: u64) -> Result<Vec<u8>, String> {
    let decoder = ruzstd::decoding::StreamingDecoder::new(data)
        .map_err(|e| format!("bad Zstandard data: {e}"))?;
    let mut out = Vec::new();
    // One byte more than expected tells a level that is too long; no more is ever read.
    decoder
        .take(expected.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| format!("bad Zstandard data: {e}"))?;
    Ok(out)
}

/// `data` if it holds exactly `expected` bytes.
fn exact(data: &[u8], expected: u64) -> Result<&[u8], String> {
    match data.len() as u64 == expected {
        true => Ok(data),
        false => Err(format!(
            "holds {} bytes where its size and format need {expected} (truncated or corrupt)",
            data.len()
        )),
    }
}

fn check_size(width: u32, height: u32) -> Result<(), String> {
    match width.max(height) <= MAX_SIDE && width > 0 && height > 0 {
        true => Ok(()),
        false => Err(format!(
            "{width}×{height} texels: sides must be 1 to {MAX_SIDE}"
        )),
    }
}

fn dds_encoding(dds: &ddsfile::Dds) -> Result<Encoding, String> {
    use ddsfile::{D3DFormat as D, DxgiFormat as X, FourCC};
    if let Some(h10) = &dds.header10 {
        return Ok(match h10.dxgi_format {
            X::R8G8B8A8_UNorm | X::R8G8B8A8_UNorm_sRGB | X::R8G8B8A8_Typeless => {
                Encoding::Texels(Texel::Rgba8)
            }
            X::B8G8R8A8_UNorm | X::B8G8R8A8_UNorm_sRGB | X::B8G8R8A8_Typeless => {
                Encoding::Texels(Texel::Bgra8)
            }
            X::B8G8R8X8_UNorm | X::B8G8R8X8_UNorm_sRGB | X::B8G8R8X8_Typeless => {
                Encoding::Texels(Texel::Bgrx8)
            }
            X::R8_UNorm | X::R8_Typeless => Encoding::Texels(Texel::R8),
            X::R8G8_UNorm | X::R8G8_Typeless => Encoding::Texels(Texel::Rg8),
            X::BC1_UNorm | X::BC1_UNorm_sRGB | X::BC1_Typeless => {
                Encoding::Blocks(Block::Bc1 { alpha: true })
            }
            X::BC2_UNorm | X::BC2_UNorm_sRGB | X::BC2_Typeless => Encoding::Blocks(Block::Bc2),
            X::BC3_UNorm | X::BC3_UNorm_sRGB | X::BC3_Typeless => Encoding::Blocks(Block::Bc3),
            X::BC4_UNorm | X::BC4_Typeless => Encoding::Blocks(Block::Bc4),
            X::BC5_UNorm | X::BC5_Typeless => Encoding::Blocks(Block::Bc5),
            X::BC6H_UF16 | X::BC6H_Typeless => Encoding::Blocks(Block::Bc6h { signed: false }),
            X::BC6H_SF16 => Encoding::Blocks(Block::Bc6h { signed: true }),
            X::BC7_UNorm | X::BC7_UNorm_sRGB | X::BC7_Typeless => Encoding::Blocks(Block::Bc7),
            other => return Err(format!("DXGI format {other:?} is not supported")),
        });
    }
    const BC4U: u32 = u32::from_le_bytes(*b"BC4U");
    const BC5U: u32 = u32::from_le_bytes(*b"BC5U");
    if let Some(FourCC(code)) = dds.header.spf.fourcc {
        return Ok(match code {
            FourCC::DXT1 => Encoding::Blocks(Block::Bc1 { alpha: true }),
            FourCC::DXT3 => Encoding::Blocks(Block::Bc2),
            FourCC::DXT5 => Encoding::Blocks(Block::Bc3),
            FourCC::ATI1 | BC4U => Encoding::Blocks(Block::Bc4),
            FourCC::ATI2 | BC5U => Encoding::Blocks(Block::Bc5),
            _ => {
                let name = code
                    .to_le_bytes()
                    .map(|b| b.is_ascii_graphic().then_some(b as char));
                let name: Option<String> = name.into_iter().collect();
                return Err(format!(
                    "FourCC {} is not supported",
                    name.unwrap_or_else(|| code.to_string())
                ));
            }
        });
    }
    match D::try_from_pixel_format(&dds.header.spf) {
        Some(D::A8B8G8R8) => Ok(Encoding::Texels(Texel::Rgba8)),
        Some(D::X8B8G8R8) => Ok(Encoding::Texels(Texel::Rgbx8)),
        Some(D::A8R8G8B8) => Ok(Encoding::Texels(Texel::Bgra8)),
        Some(D::X8R8G8B8) => Ok(Encoding::Texels(Texel::Bgrx8)),
        // Masks R 0xff0000, G 0xff00, B 0xff: bytes B, G, R.
        Some(D::R8G8B8) => Ok(Encoding::Texels(Texel::Bgr8)),
        Some(D::L8) => Ok(Encoding::Texels(Texel::R8)),
        Some(other) => Err(format!("pixel format {other:?} is not supported")),
        None => Err("its pixel format is not one of the known ones".to_owned()),
    }
}

fn dds_levels(bytes: &[u8], srgb: bool) -> Result<Levels, String> {
    use ddsfile::{Caps2, D3D10ResourceDimension, MiscFlag};
    let dds = ddsfile::Dds::read(bytes).map_err(|e| format!("not a valid file: {e}"))?;
    let header = &dds.header;
    let volume = header.depth.is_some_and(|d| d > 1) || header.caps2.contains(Caps2::VOLUME);
    let cube = header.caps2.contains(Caps2::CUBEMAP);
    let array_or_cube = dds.header10.as_ref().is_some_and(|h| {
        h.array_size > 1
            || h.misc_flag.contains(MiscFlag::TEXTURECUBE)
            || h.resource_dimension == D3D10ResourceDimension::Texture3D
    });
    if volume || cube || array_or_cube {
        return Err("only 2D textures are supported, not arrays, cube maps or volumes".to_owned());
    }
    let (width, height) = (header.width, header.height);
    check_size(width, height)?;
    let encoding = dds_encoding(&dds)?;
    let count = (header.mip_map_count.unwrap_or(1).max(1) as usize).min(level_count(width, height));
    let mut offset = 0u64;
    let mut levels = Vec::with_capacity(count);
    for l in 0..count {
        let (w, h) = (level_size(width, l), level_size(height, l));
        let size = encoding.level_bytes(w, h);
        let data = usize::try_from(offset)
            .ok()
            .zip(usize::try_from(offset + size).ok())
            .and_then(|(start, end)| dds.data.get(start..end))
            .ok_or_else(|| {
                format!(
                    "level {l} needs bytes {offset}..{} of the texel data, which has {} \
                     (truncated or corrupt)",
                    offset + size,
                    dds.data.len()
                )
            })?;
        levels.push(decode_level(encoding, data, w, h, srgb));
        offset += size;
    }
    Ok((width, height, levels, note(encoding)))
}

fn note(encoding: Encoding) -> Option<&'static str> {
    matches!(encoding, Encoding::Blocks(Block::Bc6h { .. }))
        .then_some("BC6H (HDR) texels are clamped to [0, 1]: the texture is stored in 8 bits")
}

/// A `width × height` level of `data` (exactly [`Encoding::level_bytes`] long) as RGBA8.
fn decode_level(encoding: Encoding, data: &[u8], width: u32, height: u32, srgb: bool) -> Vec<u8> {
    let block = match encoding {
        Encoding::Texels(texel) => {
            return data
                .chunks_exact(texel.bytes())
                .flat_map(|t| texel.rgba(t))
                .collect();
        }
        Encoding::Blocks(block) => block,
    };
    let (w, h) = (width as usize, height as usize);
    let unit = block.bytes();
    let blocks_x = w.div_ceil(4);
    let mut out = vec![0u8; w * h * 4];
    // One band of four texel rows per block row; the last band may be shorter.
    out.par_chunks_mut(w * 4 * 4)
        .zip(data.par_chunks(blocks_x * unit))
        .for_each(|(band, blocks)| {
            let rows = band.len() / (w * 4);
            for (bx, bytes) in blocks.chunks_exact(unit).enumerate() {
                let texels = decode_block(block, bytes, srgb);
                let columns = (w - bx * 4).min(4);
                for y in 0..rows {
                    let dst = &mut band[(y * w + bx * 4) * 4..][..columns * 4];
                    dst.copy_from_slice(&texels[y * 16..][..columns * 4]);
                }
            }
        });
    out
}

/// One 4×4 block as RGBA8, rows of 16 bytes.
fn decode_block(kind: Block, block: &[u8], srgb: bool) -> [u8; 64] {
    let mut rgba = [0u8; 64];
    match kind {
        Block::Bc1 { alpha } => {
            bcdec_rs::bc1(block, &mut rgba, 16);
            if !alpha {
                rgba.as_chunks_mut::<4>()
                    .0
                    .iter_mut()
                    .for_each(|t| t[3] = 255);
            }
        }
        Block::Bc2 => bcdec_rs::bc2(block, &mut rgba, 16),
        Block::Bc3 => bcdec_rs::bc3(block, &mut rgba, 16),
        Block::Bc7 => bcdec_rs::bc7(block, &mut rgba, 16),
        Block::Bc4 => {
            let mut r = [0u8; 16];
            bcdec_rs::bc4(block, &mut r, 4, false);
            for (t, r) in rgba.as_chunks_mut::<4>().0.iter_mut().zip(r) {
                *t = [r, r, r, 255];
            }
        }
        Block::Bc5 => {
            let mut rg = [0u8; 32];
            bcdec_rs::bc5(block, &mut rg, 8, false);
            for (t, rg) in rgba
                .as_chunks_mut::<4>()
                .0
                .iter_mut()
                .zip(rg.as_chunks::<2>().0)
            {
                *t = [rg[0], rg[1], 0, 255];
            }
        }
        Block::Bc6h { signed } => {
            let mut rgb = [0f32; 48];
            bcdec_rs::bc6h_float(block, &mut rgb, 12, signed);
            let encode = |c: f32| {
                let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
                let c = if srgb { linear_to_srgb(c) } else { c };
                (c * 255.0).round() as u8
            };
            for (t, c) in rgba
                .as_chunks_mut::<4>()
                .0
                .iter_mut()
                .zip(rgb.as_chunks::<3>().0)
            {
                *t = [encode(c[0]), encode(c[1]), encode(c[2]), 255];
            }
        }
    }
    rgba
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use ddsfile::{AlphaMode, D3D10ResourceDimension, D3DFormat, Dds, DxgiFormat};
    use ktx2::{Format, SupercompressionScheme};

    /// A KTX2 file of a `width × height` 2D texture with `levels` (in `format`'s encoding), each
    /// Zstandard-compressed if `zstd`.
    pub(crate) fn ktx2_file(
        format: Option<Format>,
        width: u32,
        height: u32,
        levels: &[Vec<u8>],
        scheme: Option<SupercompressionScheme>,
    ) -> Vec<u8> {
        let dfd_format = format.unwrap_or(Format::R8G8B8A8_UNORM);
        let (basic, _) = ktx2::dfd::Basic::from_format(dfd_format).unwrap();
        let block = ktx2::dfd::Block::Basic(basic).to_vec();
        let mut dfd = ((block.len() + 4) as u32).to_le_bytes().to_vec();
        dfd.extend(block);
        let stored: Vec<Vec<u8>> = levels
            .iter()
            .map(|l| match scheme {
                Some(SupercompressionScheme::Zstandard) => ruzstd::encoding::compress_to_vec(
                    &l[..],
                    ruzstd::encoding::CompressionLevel::Fastest,
                ),
                _ => l.clone(),
            })
            .collect();
        let dfd_offset = 80 + 24 * levels.len();
        let mut offset = dfd_offset + dfd.len();
        let mut index = Vec::new();
        for (raw, stored) in levels.iter().zip(&stored) {
            let entry = ktx2::LevelIndex {
                byte_offset: offset as u64,
                byte_length: stored.len() as u64,
                uncompressed_byte_length: raw.len() as u64,
            };
            index.extend(entry.as_bytes());
            offset += stored.len();
        }
        let header = ktx2::Header {
            format,
            type_size: 1,
            pixel_width: width,
            pixel_height: height,
            pixel_depth: 0,
            layer_count: 0,
            face_count: 1,
            level_count: levels.len() as u32,
            supercompression_scheme: scheme,
            index: ktx2::Index {
                dfd_byte_offset: dfd_offset as u32,
                dfd_byte_length: dfd.len() as u32,
                kvd_byte_offset: 0,
                kvd_byte_length: 0,
                sgd_byte_offset: 0,
                sgd_byte_length: 0,
            },
        };
        let mut file = header.as_bytes().to_vec();
        file.extend(index);
        file.extend(dfd);
        stored.into_iter().for_each(|l| file.extend(l));
        file
    }

    /// A DX10-header DDS file of `format` with `data` (all levels, packed).
    pub(crate) fn dds_file(
        format: DxgiFormat,
        width: u32,
        height: u32,
        mips: u32,
        data: &[u8],
    ) -> Vec<u8> {
        let mut dds = Dds::new_dxgi(ddsfile::NewDxgiParams {
            height,
            width,
            depth: None,
            format,
            mipmap_levels: Some(mips),
            array_layers: None,
            caps2: None,
            is_cubemap: false,
            resource_dimension: D3D10ResourceDimension::Texture2D,
            alpha_mode: AlphaMode::Straight,
        })
        .unwrap();
        dds.data = data.to_vec();
        let mut file = Vec::new();
        dds.write(&mut file).unwrap();
        file
    }

    /// A legacy (FourCC) DDS file: a DXT5-sized header with the FourCC replaced by `fourcc`.
    fn legacy_dds(fourcc: &[u8; 4], width: u32, height: u32, data: &[u8]) -> Vec<u8> {
        let mut dds = Dds::new_d3d(ddsfile::NewD3dParams {
            height,
            width,
            depth: None,
            format: D3DFormat::DXT5,
            mipmap_levels: None,
            caps2: None,
        })
        .unwrap();
        dds.data = data.to_vec();
        let mut file = Vec::new();
        dds.write(&mut file).unwrap();
        // Magic (4), then the header up to the pixel format (72) and its size and flags (8).
        file[84..88].copy_from_slice(fourcc);
        file
    }

    /// A BC1 block of two RGB565 colours and 2-bit indices (row by row, first texel lowest).
    pub(crate) fn bc1_block(c0: u16, c1: u16, index: impl Fn(usize, usize) -> u32) -> [u8; 8] {
        let mut bits = 0u32;
        for y in 0..4 {
            for x in 0..4 {
                bits |= index(x, y) << (2 * (y * 4 + x));
            }
        }
        let mut b = [0u8; 8];
        b[..2].copy_from_slice(&c0.to_le_bytes());
        b[2..4].copy_from_slice(&c1.to_le_bytes());
        b[4..].copy_from_slice(&bits.to_le_bytes());
        b
    }

    const RED_565: u16 = 0xF800;
    const BLUE_565: u16 = 0x001F;

    /// BC1 block: red where x + y is even, blue elsewhere (4-colour mode: c0 > c1).
    fn red_blue_checker() -> [u8; 8] {
        bc1_block(RED_565, BLUE_565, |x, y| ((x + y) % 2) as u32)
    }

    fn texel(rgba: &[u8], width: u32, x: u32, y: u32) -> [u8; 4] {
        rgba[((y * width + x) * 4) as usize..][..4]
            .try_into()
            .unwrap()
    }

    fn checker_expected(x: u32, y: u32) -> [u8; 4] {
        // RGB565 endpoints expand to 8 bits by bit replication: 31 -> 255.
        match (x + y) % 2 {
            0 => [255, 0, 0, 255],
            _ => [0, 0, 255, 255],
        }
    }

    #[test]
    fn ktx2_rgba8_keeps_a_complete_chain_and_its_own_texels() {
        // 2×1 then 1×1; the 1×1 level is not the average of level 0, so it must be the file's.
        let levels = vec![vec![10, 20, 30, 40, 50, 60, 70, 80], vec![1, 2, 3, 4]];
        let file = ktx2_file(Some(Format::R8G8B8A8_SRGB), 2, 1, &levels, None);
        let d = decode(&file, true).unwrap();
        assert_eq!((d.width, d.height), (2, 1));
        assert_eq!(d.levels, levels);
        assert_eq!(d.note, None);
    }

    #[test]
    fn ktx2_with_a_partial_chain_gets_generated_mips() {
        let level0 = vec![
            0, 0, 0, 255, 200, 100, 50, 255, 0, 0, 0, 255, 200, 100, 50, 255,
        ];
        // 4×1 with only level 0 declared: levels 2×1 and 1×1 are generated (linear: averages).
        let file = ktx2_file(
            Some(Format::R8G8B8A8_UNORM),
            4,
            1,
            std::slice::from_ref(&level0),
            None,
        );
        let d = decode(&file, false).unwrap();
        assert_eq!(d.levels.len(), 3);
        assert_eq!(d.levels[0], level0);
        assert_eq!(d.levels[1], [100, 50, 25, 255, 100, 50, 25, 255]);
        assert_eq!(d.levels[2], [100, 50, 25, 255]);
    }

    #[test]
    fn ktx2_bgra_rgb_r_and_rg_become_rgba() {
        let cases: [(Format, Vec<u8>, [u8; 4]); 4] = [
            (Format::B8G8R8A8_UNORM, vec![1, 2, 3, 4], [3, 2, 1, 4]),
            (Format::R8G8B8_SRGB, vec![1, 2, 3], [1, 2, 3, 255]),
            (Format::R8_UNORM, vec![9], [9, 9, 9, 255]),
            (Format::R8G8_UNORM, vec![7, 8], [7, 8, 0, 255]),
        ];
        for (format, bytes, expected) in cases {
            let file = ktx2_file(Some(format), 1, 1, &[bytes], None);
            let d = decode(&file, true).unwrap();
            assert_eq!(d.levels, [expected.to_vec()], "{format:?}");
        }
    }

    #[test]
    fn ktx2_bc1_decodes_known_texels_with_partial_edge_blocks() {
        // 6×5: 2×2 blocks, the right and bottom ones partial.
        let block = red_blue_checker();
        let data = block.repeat(4);
        let file = ktx2_file(Some(Format::BC1_RGB_SRGB_BLOCK), 6, 5, &[data], None);
        let d = decode(&file, true).unwrap();
        assert_eq!(d.levels[0].len(), 6 * 5 * 4);
        for y in 0..5 {
            for x in 0..6 {
                // Each block restarts the checker at its corner.
                assert_eq!(
                    texel(&d.levels[0], 6, x, y),
                    checker_expected(x % 4, y % 4),
                    "({x}, {y})"
                );
            }
        }
        assert_eq!(d.levels.len(), 3);
    }

    #[test]
    fn bc1_transparent_texels_are_opaque_black_in_rgb_formats() {
        // c0 <= c1: 3-colour mode, index 3 is transparent black.
        let block = bc1_block(BLUE_565, RED_565, |_, _| 3);
        let rgba = decode(
            &ktx2_file(
                Some(Format::BC1_RGBA_UNORM_BLOCK),
                4,
                4,
                &[block.to_vec()],
                None,
            ),
            false,
        )
        .unwrap();
        assert_eq!(texel(&rgba.levels[0], 4, 1, 1), [0, 0, 0, 0]);
        let rgb = decode(
            &ktx2_file(
                Some(Format::BC1_RGB_UNORM_BLOCK),
                4,
                4,
                &[block.to_vec()],
                None,
            ),
            false,
        )
        .unwrap();
        assert_eq!(texel(&rgb.levels[0], 4, 1, 1), [0, 0, 0, 255]);
    }

    /// A BC3 block: alpha endpoints `a0`, `a1` with every 3-bit index `alpha_index`, then colour.
    fn bc3_block(a0: u8, a1: u8, alpha_index: u64, colour: [u8; 8]) -> [u8; 16] {
        let mut b = [0u8; 16];
        b[0] = a0;
        b[1] = a1;
        let indices: u64 = (0..16).map(|i| alpha_index << (3 * i)).sum();
        b[2..8].copy_from_slice(&indices.to_le_bytes()[..6]);
        b[8..].copy_from_slice(&colour);
        b
    }

    #[test]
    fn dds_bc3_and_legacy_dxt5_decode_known_texels() {
        // Alpha index 1 selects a1 = 100.
        let block = bc3_block(200, 100, 1, red_blue_checker());
        for file in [
            dds_file(DxgiFormat::BC3_UNorm_sRGB, 4, 4, 1, &block),
            legacy_dds(b"DXT5", 4, 4, &block),
        ] {
            let d = decode(&file, true).unwrap();
            for (x, y) in [(0, 0), (1, 0), (3, 3), (2, 1)] {
                let [r, g, b, _] = checker_expected(x, y);
                assert_eq!(texel(&d.levels[0], 4, x, y), [r, g, b, 100]);
            }
        }
    }

    #[test]
    fn bc4_is_grey_and_bc5_is_red_green() {
        // BC4: r0 = 200, r1 = 100, every index 1 (r1).
        let mut bc4 = [0u8; 8];
        bc4[0] = 200;
        bc4[1] = 100;
        let indices: u64 = (0..16).map(|i| 1u64 << (3 * i)).sum();
        bc4[2..].copy_from_slice(&indices.to_le_bytes()[..6]);
        let mut bc5 = bc4.to_vec();
        // Green: every index 0 (g0 = 50).
        bc5.extend([50, 10, 0, 0, 0, 0, 0, 0]);
        for file in [
            dds_file(DxgiFormat::BC4_UNorm, 4, 4, 1, &bc4),
            legacy_dds(b"ATI1", 4, 4, &bc4),
            legacy_dds(b"BC4U", 4, 4, &bc4),
            ktx2_file(Some(Format::BC4_UNORM_BLOCK), 4, 4, &[bc4.to_vec()], None),
        ] {
            assert_eq!(
                texel(&decode(&file, false).unwrap().levels[0], 4, 2, 3),
                [100, 100, 100, 255]
            );
        }
        for file in [
            dds_file(DxgiFormat::BC5_UNorm, 4, 4, 1, &bc5),
            legacy_dds(b"ATI2", 4, 4, &bc5),
            legacy_dds(b"BC5U", 4, 4, &bc5),
            ktx2_file(Some(Format::BC5_UNORM_BLOCK), 4, 4, &[bc5.clone()], None),
        ] {
            assert_eq!(
                texel(&decode(&file, false).unwrap().levels[0], 4, 1, 2),
                [100, 50, 0, 255]
            );
        }
    }

    /// Writes `value`'s low `bits` bits at bit `at` of `block` (least significant bit first).
    fn put_bits(block: &mut [u8; 16], at: usize, bits: usize, value: u32) {
        for i in 0..bits {
            if value >> i & 1 == 1 {
                block[(at + i) / 8] |= 1 << ((at + i) % 8);
            }
        }
    }

    #[test]
    fn bc7_mode_6_decodes_its_first_endpoint() {
        // Mode 6: bit 6 set; 7-bit endpoints R0 R1 G0 G1 B0 B1 A0 A1, p-bits P0 P1, then indices
        // (all zero: every texel is endpoint 0, (E0 << 1) | P0).
        let mut block = [0u8; 16];
        put_bits(&mut block, 0, 7, 1 << 6);
        let endpoints = [0x7F, 0, 0x40, 0, 0x10, 0, 0x3F, 0];
        for (i, e) in endpoints.iter().enumerate() {
            put_bits(&mut block, 7 + 7 * i, 7, *e);
        }
        put_bits(&mut block, 63, 1, 1);
        let expected = [0xFF, 0x81, 0x21, 0x7F];
        for file in [
            dds_file(DxgiFormat::BC7_UNorm_sRGB, 4, 4, 1, &block),
            ktx2_file(Some(Format::BC7_SRGB_BLOCK), 4, 4, &[block.to_vec()], None),
        ] {
            let d = decode(&file, true).unwrap();
            assert!(
                d.levels[0]
                    .as_chunks::<4>()
                    .0
                    .iter()
                    .all(|t| *t == expected),
                "{:?}",
                &d.levels[0][..4]
            );
        }
    }

    #[test]
    fn bc6h_is_clamped_with_a_note() {
        // Mode 11 (bits 00011): 10-bit endpoints; endpoint 0 all ones is half 65504, far above 1.
        let mut block = [0u8; 16];
        put_bits(&mut block, 0, 5, 0b00011);
        for c in 0..3 {
            put_bits(&mut block, 5 + 10 * c, 10, 0x3FF);
        }
        let file = dds_file(DxgiFormat::BC6H_UF16, 4, 4, 1, &block);
        let d = decode(&file, true).unwrap();
        assert!(d.note.is_some_and(|n| n.contains("BC6H")));
        assert_eq!(texel(&d.levels[0], 4, 3, 3), [255, 255, 255, 255]);
    }

    #[test]
    fn dds_keeps_its_levels() {
        // RGBA8 4×2, 2×1, 1×1 with a last level that is not the average.
        let data: Vec<u8> = (0..(8 + 2 + 1) * 4).map(|i| i as u8).collect();
        let d = decode(&dds_file(DxgiFormat::R8G8B8A8_UNorm, 4, 2, 3, &data), false).unwrap();
        assert_eq!(
            d.levels,
            [
                data[..32].to_vec(),
                data[32..40].to_vec(),
                data[40..].to_vec()
            ]
        );
        let bgra = decode(
            &dds_file(DxgiFormat::B8G8R8A8_UNorm_sRGB, 1, 1, 1, &[1, 2, 3, 4]),
            true,
        )
        .unwrap();
        assert_eq!(bgra.levels, [vec![3, 2, 1, 4]]);
    }

    #[test]
    fn zstd_supercompressed_ktx2_levels_decode() {
        let levels = vec![(0..16 * 4).map(|i| (i * 3) as u8).collect::<Vec<u8>>()];
        let file = ktx2_file(
            Some(Format::R8G8B8A8_UNORM),
            4,
            4,
            &levels,
            Some(SupercompressionScheme::Zstandard),
        );
        assert_eq!(decode(&file, false).unwrap().levels[0], levels[0]);
    }

    #[test]
    fn basis_universal_payloads_are_refused_clearly() {
        let basis = ktx2_file(
            None,
            4,
            4,
            &[vec![0; 16]],
            Some(SupercompressionScheme::BasisLZ),
        );
        let why = decode(&basis, true).unwrap_err();
        assert!(why.contains("BasisLZ"), "{why}");
        let uastc = ktx2_file(None, 4, 4, &[vec![0; 16]], None);
        let why = decode(&uastc, true).unwrap_err();
        assert!(why.contains("Basis Universal"), "{why}");
    }

    #[test]
    fn truncated_and_corrupt_files_are_errors_not_panics() {
        let bc1 = red_blue_checker().repeat(4);
        let files = [
            ktx2_file(
                Some(Format::BC1_RGB_SRGB_BLOCK),
                8,
                8,
                std::slice::from_ref(&bc1),
                None,
            ),
            ktx2_file(
                Some(Format::R8G8B8A8_UNORM),
                2,
                2,
                &[vec![7; 16], vec![1; 4]],
                Some(SupercompressionScheme::Zstandard),
            ),
            dds_file(DxgiFormat::BC1_UNorm, 8, 8, 1, &bc1),
            legacy_dds(b"DXT5", 4, 4, &[0; 16]),
        ];
        for file in &files {
            decode(file, true).unwrap();
            for len in 0..file.len() {
                let why = decode(&file[..len], true).unwrap_err();
                assert!(!why.is_empty());
            }
            // Flipped bytes, and random 32-bit values written anywhere (header fields: sizes,
            // offsets, formats): anything may come out, but no panic.
            for i in 0..file.len() {
                let mut bad = file.clone();
                bad[i] ^= 0xFF;
                let _ = decode(&bad, true);
            }
            let mut state = 0x9E37_79B9_7F4A_7C15u64;
            for _ in 0..3000 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let mut bad = file.clone();
                let at = (state % (file.len() as u64 - 3)) as usize;
                bad[at..at + 4].copy_from_slice(&((state >> 32) as u32).to_le_bytes());
                let _ = decode(&bad, true);
            }
        }
        let why = decode(&files[2][..files[2].len() - 1], true).unwrap_err();
        assert!(why.contains("DDS") && why.contains("truncated"), "{why}");
    }
}
