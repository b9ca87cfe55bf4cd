//! Debug views of a GI frame, one image per stage: the probe atlas, the probe mask, spawn and
//! patch tiles, the ray-guiding PDFs, the cache's cells at each pixel, the blur mask, the probes'
//! age (ProbeAgeView, a pass of its own), and the irradiance before and after the denoiser.

use super::debug_views::{DebugView, debug_views, write_pngs};
use super::gi_denoiser::DenoiserStage;
use super::renderer::GiRenderer;
use crate::error::{Error, Result};
use crate::frame::Recorder;
use crate::image_io::HdrImage;
use crate::vulkan::{Buffer, Context, Kernel, KernelModule};
use gi_shared::color::luminance;
use gi_shared::hash_cells::layout::HashCellValue;
use gi_shared::packing::{SEED_NONE, unpack_seed};
use gi_shared::screen_probes::hemisphere::{ProbeFrame, cell_coords};
use gi_shared::screen_probes::{
    EMPTY_COUNT, NO_PROBE, PROBE_CELLS, PROBE_SIZE, ProbeRecord, StoredCell, cell_is_filled,
};
use glam::Vec3;
use std::path::{Path, PathBuf};

/// One debug image: its file name (without extension), the image, and whether it holds
/// radiance (tone-mapped with the exposure) rather than a false-colour code.
pub struct GiDebugView {
    /// File name without extension.
    pub name: String,
    /// The image.
    pub image: HdrImage,
    /// Radiance or irradiance, tone-mapped with the exposure.
    pub radiance: bool,
}

crate::bindings! {
    /// ProbeAgeView's set 0 (`kernels::screen_probes::probe_age_view`).
    pub(crate) struct ProbeAgeView<'a> {
        frame: &'a Buffer,
        records: &'a Buffer,
        colours: &'a Buffer,
    }
}

/// ProbeAgeView, run on the last frame's probes: each pixel in the colour of its tile's probe
/// age (`ProbeRecord::age_colour`).
fn probe_age_view(ctx: &Context, gi: &GiRenderer, [w, h]: [u32; 2]) -> Result<Vec<[f32; 3]>> {
    let module = KernelModule::new(ctx)?;
    let kernel = Kernel::new::<ProbeAgeView>(ctx, &module, "screen_probes::probe_age_view", 0)?;
    let colours = Buffer::device_zeroed::<[f32; 4]>(ctx, "probe age view", (w * h) as usize)?;
    let probes = gi.probes();
    let bindings = ProbeAgeView {
        frame: &probes.frame,
        records: probes.records.current(),
        colours: &colours,
    };
    ctx.submit(|cmd| {
        let mut rec = Recorder::new(ctx, cmd, None);
        rec.begin();
        rec.pass("ProbeAgeView", |rec| {
            rec.dispatch(&kernel, &bindings, &[], [w.div_ceil(8), h.div_ceil(8), 1])
        })?;
        rec.finish();
        Ok::<_, Error>(())
    })??;
    let texels: Vec<[f32; 4]> = colours.read_back(ctx)?;
    Ok(texels.iter().map(|c| [c[0], c[1], c[2]]).collect())
}

/// A colour per index, stable across frames.
fn false_colour(i: u32) -> [f32; 3] {
    let h = gi_shared::hash::pcg(i);
    [
        (h & 0xff) as f32 / 255.0,
        ((h >> 8) & 0xff) as f32 / 255.0,
        ((h >> 16) & 0xff) as f32 / 255.0,
    ]
}

/// Every debug view of the renderer's last frame.
pub fn gi_debug_views(ctx: &Context, gi: &GiRenderer) -> Result<Vec<GiDebugView>> {
    if !gi.denoiser().keeps_interpolated() {
        return Err(Error::InvalidArgument {
            name: "debug views",
            why: "the irradiance before the denoiser was not kept: call \
                  GiRenderer::keep_interpolated_irradiance before the first frame"
                .into(),
        });
    }
    let Some((camera, params, frame)) = gi.last_frame() else {
        return Err(Error::InvalidArgument {
            name: "debug views",
            why: "no frame rendered yet".into(),
        });
    };
    let [w, h] = frame.image_size;
    let probes = gi.probes();
    let layout = probes.layout;
    let [gx, gy] = layout.probe_grid;
    let records: Vec<ProbeRecord> = probes.records.current().read_back(ctx)?;
    let unpack = |v: Vec<StoredCell>| v.iter().map(|c| c.unpack()).collect::<Vec<_>>();
    let atlas = unpack(probes.atlas.current().read_back(ctx)?);
    let mask: Vec<u32> = probes.mask.current().read_back(ctx)?;
    let spawns: Vec<u32> = probes.spawns.read_back(ctx)?;
    let empty: Vec<u32> = probes.empty_tiles.read_back(ctx)?;
    let history = unpack(probes.history.read_back(ctx)?);
    let counters: Vec<u32> = probes.counters.read_back(ctx)?;
    let mut views = vec![];
    let mut push = |name: &str, width: u32, height: u32, pixels: Vec<[f32; 3]>, radiance| {
        HdrImage::from_pixels(width, height, pixels).map(|image| {
            views.push(GiDebugView {
                name: name.into(),
                image,
                radiance,
            })
        })
    };
    // The atlas: each probe tile's 8 × 8 cells where its pixels are.
    let atlas_pixels = (0..gy * PROBE_SIZE)
        .flat_map(|y| (0..gx * PROBE_SIZE).map(move |x| (x, y)))
        .map(|(x, y)| {
            let tile = (y / PROBE_SIZE) * gx + x / PROBE_SIZE;
            let cell = (y % PROBE_SIZE) * PROBE_SIZE + x % PROBE_SIZE;
            let c = atlas[(tile * PROBE_CELLS + cell) as usize];
            if records[tile as usize].is_valid() && cell_is_filled(c) {
                [c[0], c[1], c[2]]
            } else {
                [0.0; 3]
            }
        })
        .collect();
    push(
        "probe_atlas",
        gx * PROBE_SIZE,
        gy * PROBE_SIZE,
        atlas_pixels,
        true,
    )?;
    // The mask: a colour per probe at every pixel of its tile, black for none.
    let mask_pixels = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let m = mask[((y / PROBE_SIZE) * gx + x / PROBE_SIZE) as usize];
            if m == NO_PROBE {
                [0.0; 3]
            } else {
                false_colour(m)
            }
        })
        .collect();
    push("probe_mask", w, h, mask_pixels, false)?;
    // Spawn and patch tiles: green where a probe was traced this frame (white at its seed),
    // red where a tile was left empty (disoccluded, patched when patching is on).
    let mut tiles = vec![[0.0f32; 3]; (w * h) as usize];
    let mut paint = |tile: u32, colour: [f32; 3]| {
        let (tx, ty) = (tile % gx, tile / gx);
        for y in ty * PROBE_SIZE..((ty + 1) * PROBE_SIZE).min(h) {
            for x in tx * PROBE_SIZE..((tx + 1) * PROBE_SIZE).min(w) {
                tiles[(y * w + x) as usize] = colour;
            }
        }
    };
    for &t in empty.iter().take(counters[EMPTY_COUNT] as usize) {
        paint(t, [0.8, 0.1, 0.1]);
    }
    // Each spawn tile owns its slot; sky spawns hold no seed.
    let spawned: Vec<u32> = spawns.iter().copied().filter(|&s| s != SEED_NONE).collect();
    for &s in &spawned {
        let p = unpack_seed(s);
        paint((p.y / PROBE_SIZE) * gx + p.x / PROBE_SIZE, [0.1, 0.6, 0.1]);
    }
    for &s in &spawned {
        let p = unpack_seed(s);
        if p.x < w && p.y < h {
            tiles[(p.y * w + p.x) as usize] = [1.0; 3];
        }
    }
    push("spawn_and_patch_tiles", w, h, tiles, false)?;
    // Ray guiding: each spawned probe's PDF over its cells (history luminance × cosine,
    // normalised to its maximum), in the atlas layout at the probe's tile.
    let mut pdf = vec![[0.0f32; 3]; (gx * gy * PROBE_CELLS) as usize];
    for (i, &s) in spawned.iter().enumerate() {
        let p = unpack_seed(s);
        let tile = (p.y / PROBE_SIZE) * gx + p.x / PROBE_SIZE;
        let record = records[tile as usize];
        let frame_of = ProbeFrame {
            position: record.world_position(),
            normal: record.world_normal(),
        };
        let weights: Vec<f32> = (0..PROBE_CELLS)
            .map(|c| {
                let hc = history[i * PROBE_CELLS as usize + c as usize];
                let cos = frame_of.cell_direction(c).dot(frame_of.normal).max(0.0);
                if cell_is_filled(hc) {
                    luminance(Vec3::new(hc[0], hc[1], hc[2])) * cos
                } else {
                    0.0
                }
            })
            .collect();
        let max = weights.iter().copied().fold(0.0f32, f32::max);
        for c in 0..PROBE_CELLS {
            let v = if max > 0.0 {
                weights[c as usize] / max
            } else {
                0.0
            };
            let cc = cell_coords(c);
            let x = (tile % gx) * PROBE_SIZE + cc.x;
            let y = (tile / gx) * PROBE_SIZE + cc.y;
            pdf[(y * gx * PROBE_SIZE + x) as usize] = [v, v, v];
        }
    }
    push(
        "ray_guiding_pdf",
        gx * PROBE_SIZE,
        gy * PROBE_SIZE,
        pdf,
        false,
    )?;
    // The denoiser.
    let denoiser = gi.denoiser();
    let blur: Vec<f32> = denoiser.blur_radius.read_back(ctx)?;
    let blur_pixels = blur
        .iter()
        .map(|&r| {
            if r < 0.0 {
                [0.0, 0.0, 0.3]
            } else {
                [r / 8.0; 3]
            }
        })
        .collect();
    push("blur_mask", w, h, blur_pixels, false)?;
    push("probe_age", w, h, probe_age_view(ctx, gi, [w, h])?, false)?;
    let rgb = |v: Vec<[f32; 4]>| v.iter().map(|c| [c[0], c[1], c[2]]).collect::<Vec<_>>();
    let before: Vec<[f32; 4]> = denoiser.irradiance.read_back(ctx)?;
    push("irradiance_before_denoiser", w, h, rgb(before), true)?;
    let settings = gi.settings();
    let after: Vec<[f32; 4]> = denoiser
        .output(DenoiserStage::last(settings))
        .read_back(ctx)?;
    push("irradiance_after_denoiser", w, h, rgb(after), true)?;
    // The world cache's cells at each pixel's primary hit.
    let data = gi.gbuffer().read_back(ctx)?;
    let cache = gi.cache_resources();
    let keys: Vec<u32> = cache.keys.read_back(ctx)?;
    let values: Vec<HashCellValue> = cache.values.read_back(ctx)?;
    for (view, image) in debug_views(camera, &params.grid, &data, &keys, &keys, &values)? {
        if view != DebugView::Evicted {
            views.push(GiDebugView {
                name: format!("cache_{}", view.name()),
                image,
                radiance: view == DebugView::Radiance,
            });
        }
    }
    Ok(views)
}

/// Writes each view as `dir/<name>.png` (radiance tone-mapped with `exposure`); returns the
/// paths.
pub fn write_gi_debug_views(
    views: &[GiDebugView],
    dir: &Path,
    exposure: f32,
) -> Result<Vec<PathBuf>> {
    write_pngs(
        dir,
        views
            .iter()
            .map(|v| (v.name.as_str(), &v.image, v.radiance)),
        exposure,
    )
}
