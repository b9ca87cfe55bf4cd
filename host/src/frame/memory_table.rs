//! Every live resource's size by name, as a table with a total: what each pass's buffers and
//! images cost in memory.

use crate::vulkan::{BufferInfo, Context, MemoryLocation};
use std::fmt;

/// One resource of a [`MemoryTable`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MemoryRow {
    /// The name it was created with.
    pub name: String,
    /// `buffer` or `image`.
    pub kind: &'static str,
    /// Its size in bytes.
    pub bytes: u64,
    /// The memory location it asked for.
    pub location: MemoryLocation,
}

/// The live resources of a context, largest first.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MemoryTable {
    /// The rows, largest first (ties in name order).
    pub rows: Vec<MemoryRow>,
}

/// Bytes per MiB.
const MIB: f64 = 1024.0 * 1024.0;

fn location_name(location: MemoryLocation) -> &'static str {
    match location {
        MemoryLocation::GpuOnly => "device",
        MemoryLocation::CpuToGpu => "host → device",
        MemoryLocation::GpuToCpu => "device → host",
        MemoryLocation::Unknown => "unknown",
    }
}

impl MemoryTable {
    /// The buffers and images alive on `ctx` now.
    pub fn of(ctx: &Context) -> Self {
        Self::new(&ctx.live_buffers(), &ctx.live_images())
    }

    /// A table of `buffers` and `images` (as [`Context::live_buffers`] and
    /// [`Context::live_images`] list them).
    pub fn new(buffers: &[BufferInfo], images: &[BufferInfo]) -> Self {
        let row = |kind| {
            move |b: &BufferInfo| MemoryRow {
                name: b.name.clone(),
                kind,
                bytes: b.bytes,
                location: b.location,
            }
        };
        let mut rows: Vec<MemoryRow> = buffers
            .iter()
            .map(row("buffer"))
            .chain(images.iter().map(row("image")))
            .collect();
        rows.sort_by(|a, b| b.bytes.cmp(&a.bytes).then_with(|| a.name.cmp(&b.name)));
        Self { rows }
    }

    /// The sum of every row.
    pub fn total_bytes(&self) -> u64 {
        self.rows.iter().map(|r| r.bytes).sum()
    }
}

impl fmt::Display for MemoryTable {
    /// One line per resource (name, kind, bytes, MiB with three decimals, location), then the
    /// total.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let width = self
            .rows
            .iter()
            .map(|r| r.name.chars().count())
            .chain(["resource".len(), "total".len()])
            .max()
            .unwrap_or(0);
        writeln!(
            f,
            "{:<width$}  {:<6}  {:>12}  {:>10}  location",
            "resource", "kind", "bytes", "MiB"
        )?;
        for r in &self.rows {
            writeln!(
                f,
                "{:<width$}  {:<6}  {:>12}  {:>10.3}  {}",
                r.name,
                r.kind,
                r.bytes,
                r.bytes as f64 / MIB,
                location_name(r.location)
            )?;
        }
        write!(
            f,
            "{:<width$}  {:<6}  {:>12}  {:>10.3}",
            "total",
            "",
            self.total_bytes(),
            self.total_bytes() as f64 / MIB
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(name: &str, bytes: u64, location: MemoryLocation) -> BufferInfo {
        BufferInfo {
            name: name.into(),
            bytes,
            location,
        }
    }

    #[test]
    fn rows_are_largest_first_and_the_total_adds_up() {
        let table = MemoryTable::new(
            &[
                info("camera", 256, MemoryLocation::CpuToGpu),
                info("radiance cache", 3 << 20, MemoryLocation::GpuOnly),
            ],
            &[info("albedo", 1 << 20, MemoryLocation::GpuOnly)],
        );
        let names: Vec<_> = table.rows.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, ["radiance cache", "albedo", "camera"]);
        assert_eq!(table.rows[1].kind, "image");
        assert_eq!(table.total_bytes(), (4 << 20) + 256);
        let text = table.to_string();
        let lines: Vec<_> = text.lines().collect();
        assert_eq!(lines.len(), 5, "{text}");
        assert!(lines[0].starts_with("resource"), "{text}");
        assert_eq!(
            lines[1].split_whitespace().collect::<Vec<_>>(),
            ["radiance", "cache", "buffer", "3145728", "3.000", "device"]
        );
        assert!(
            lines[3].ends_with("256       0.000  host → device"),
            "{text}"
        );
        assert_eq!(
            lines[4].split_whitespace().collect::<Vec<_>>(),
            ["total", "4194560", "4.000"]
        );
        // Columns line up: every size ends at the same character.
        let end = |l: &str| l.find(".000").map(|i| l[..i].chars().count());
        assert_eq!(end(lines[1]), end(lines[4]));
        assert_eq!(end(lines[2]), end(lines[4]));
    }

    #[test]
    fn an_empty_table_totals_zero() {
        let table = MemoryTable::new(&[], &[]);
        assert_eq!(table.total_bytes(), 0);
        assert_eq!(table.to_string().lines().count(), 2);
    }
}
