//! The shipped kernel modules (`host/kernels-spirv/`) and their manifest: what they were built
//! from (toolchain, spirv-builder, a hash of the kernel sources) and each module's size and hash.
//!
//! The sources hash covers everything that shapes the modules: `kernels/` and `shared/` (manifests
//! and `src/`), the toolchain file, the kernel build options (`build/kernels.rs`), the workspace's
//! dependency entries and release profile that the kernels inherit, and the `Cargo.lock` entries of
//! the kernels' dependencies and of rust-gpu's builder and backend. Nothing else in the lock
//! counts, so adding a dependency to the host does not make the modules stale.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;
use std::hash::Hasher;
use std::path::{Path, PathBuf};
use twox_hash::XxHash64;

/// The module files, software variant first.
pub const MODULES: [&str; 2] = ["software.spv", "ray-query.spv"];
/// The manifest's file name, beside the modules.
pub const MANIFEST: &str = "manifest.toml";

/// What a set of modules was built from.
pub struct Provenance {
    toolchain: String,
    spirv_builder: String,
    /// xxHash64 of the sources, 16 hex digits.
    sources: String,
}

/// Sources, relative to the repository root, whose text is hashed as is.
const HASHED_FILES: &[&str] = &[
    "rust-toolchain.toml",
    "host/build/kernels.rs",
    "kernels/Cargo.toml",
    "shared/Cargo.toml",
];
/// Directories, relative to the repository root, every file of which is hashed.
const HASHED_DIRS: &[&str] = &["kernels/src", "shared/src"];
/// The workspace's manifest and lock, relative to the repository root: parts of them are hashed.
const WORKSPACE_MANIFEST: &str = "Cargo.toml";
const LOCK: &str = "Cargo.lock";
/// The crates whose manifests' dependencies the kernels are built with.
const KERNEL_CRATES: &[&str] = &["kernels", "shared"];
/// rust-gpu's builder and backend: their lock entries count, not their dependencies'.
const BUILDER_PACKAGES: &[&str] = &["spirv-builder", "rustc_codegen_spirv"];

/// Every input of the sources hash, relative to the repository root: what a build script
/// watches.
pub fn inputs() -> impl Iterator<Item = &'static str> {
    HASHED_FILES
        .iter()
        .chain(HASHED_DIRS)
        .copied()
        .chain([WORKSPACE_MANIFEST, LOCK])
}

impl Provenance {
    /// Reads the sources in the repository at `repo`; `None` where they are absent (a packaged
    /// crate, whose manifest is trusted).
    pub fn of_sources(repo: &Path) -> Result<Option<Self>, String> {
        if !repo.join("kernels/Cargo.toml").is_file() {
            return Ok(None);
        }
        let mut inputs: BTreeMap<String, Vec<u8>> = BTreeMap::new();
        for file in HASHED_FILES {
            inputs.insert((*file).into(), read(&repo.join(file))?);
        }
        for dir in HASHED_DIRS {
            for file in files_under(&repo.join(dir))? {
                let rel = file
                    .strip_prefix(repo)
                    .expect("walked below the repository")
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy())
                    .collect::<Vec<_>>()
                    .join("/");
                inputs.insert(rel, read(&file)?);
            }
        }
        let toolchain = toml_file(&repo.join("rust-toolchain.toml"))?;
        let toolchain = toolchain
            .get("toolchain")
            .and_then(|t| t.get("channel"))
            .and_then(|c| c.as_str())
            .ok_or("rust-toolchain.toml names no toolchain.channel")?
            .to_string();

        // What the kernel crates inherit from the workspace.
        let workspace = toml_file(&repo.join(WORKSPACE_MANIFEST))?;
        let workspace_deps = workspace
            .get("workspace")
            .and_then(|w| w.get("dependencies"))
            .and_then(|d| d.as_table());
        if let Some(release) = workspace.get("profile").and_then(|p| p.get("release")) {
            inputs.insert(
                "Cargo.toml:profile.release".into(),
                release.to_string().into(),
            );
        }
        let mut roots = BTreeSet::new();
        for krate in KERNEL_CRATES {
            let manifest = toml_file(&repo.join(krate).join("Cargo.toml"))?;
            let deps = manifest.get("dependencies").and_then(|d| d.as_table());
            for (name, spec) in deps.into_iter().flatten() {
                let spec = if spec.get("workspace").and_then(|w| w.as_bool()) == Some(true) {
                    let inherited = workspace_deps.and_then(|d| d.get(name)).ok_or_else(|| {
                        format!("{krate}/Cargo.toml: {name} is not a workspace dependency")
                    })?;
                    inputs.insert(
                        format!("Cargo.toml:workspace.dependencies.{name}"),
                        inherited.to_string().into(),
                    );
                    inherited
                } else {
                    spec
                };
                // Path dependencies are hashed as sources.
                if spec.get("path").is_none() {
                    roots.insert(name.clone());
                }
            }
        }

        let lock = Lock::read(&repo.join(LOCK))?;
        let mut spirv_builder = None;
        for (key, entry) in lock.closure(&roots) {
            inputs.insert(format!("Cargo.lock:{key}"), entry.into());
        }
        for name in BUILDER_PACKAGES {
            for (version, entry) in lock.entries(name) {
                if *name == "spirv-builder" {
                    spirv_builder = Some(version.clone());
                }
                inputs.insert(format!("Cargo.lock:{name} {version}"), entry.into());
            }
        }
        let spirv_builder = spirv_builder.ok_or("Cargo.lock has no spirv-builder")?;

        let mut hasher = XxHash64::with_seed(0);
        for (name, bytes) in &inputs {
            // Line endings as git wrote them on this machine do not count.
            let text: Vec<u8> = bytes
                .iter()
                .enumerate()
                .filter(|&(i, &b)| !(b == b'\r' && bytes.get(i + 1) == Some(&b'\n')))
                .map(|(_, &b)| b)
                .collect();
            hasher.write(name.as_bytes());
            hasher.write(&(text.len() as u64).to_le_bytes());
            hasher.write(&text);
        }
        Ok(Some(Self {
            toolchain,
            spirv_builder,
            sources: format!("{:016x}", hasher.finish()),
        }))
    }

    /// What a manifest says the modules beside it were built from.
    fn of_manifest(text: &str) -> Result<Self, String> {
        let table: toml::Table = text.parse().map_err(|e| format!("{e}"))?;
        let field = |key: &str| {
            table
                .get(key)
                .and_then(|v| v.as_str())
                .map(str::to_string)
                .ok_or_else(|| format!("no {key}"))
        };
        Ok(Self {
            toolchain: field("toolchain")?,
            spirv_builder: field("spirv-builder")?,
            sources: field("sources-xxh64")?,
        })
    }

    /// The manifest of `modules` (file name and bytes, in `MODULES` order) built from these
    /// sources.
    pub fn manifest(&self, modules: &[(&str, Vec<u8>)]) -> String {
        let mut text = format!(
            "# The rust-gpu kernel modules beside this file and what they were built from. Written by\n\
             # scripts/build-kernels.sh; gi-host's build script checks it (host/build/manifest.rs).\n\
             toolchain = \"{}\"\n\
             spirv-builder = \"{}\"\n\
             sources-xxh64 = \"{}\"\n",
            self.toolchain, self.spirv_builder, self.sources
        );
        for (file, bytes) in modules {
            let _ = write!(
                text,
                "\n[modules.\"{file}\"]\nbytes = {}\nxxh64 = \"{:016x}\"\n",
                bytes.len(),
                XxHash64::oneshot(0, bytes)
            );
        }
        text
    }
}

/// Reads the modules in `dir`, in `MODULES` order.
pub fn read_modules(dir: &Path) -> Result<Vec<(&'static str, Vec<u8>)>, String> {
    MODULES
        .iter()
        .map(|file| Ok((*file, read(&dir.join(file))?)))
        .collect()
}

/// Checks the modules and manifest in `dir` against each other and, where given, against the
/// sources: an error lists the manifest lines that differ from what they should be.
pub fn check(dir: &Path, sources: Option<&Provenance>) -> Result<(), String> {
    let shipped = String::from_utf8(read(&dir.join(MANIFEST))?)
        .map_err(|e| format!("{}: {e}", dir.join(MANIFEST).display()))?;
    let from_manifest;
    let provenance = match sources {
        Some(p) => p,
        None => {
            from_manifest = Provenance::of_manifest(&shipped)
                .map_err(|e| format!("{}: {e}", dir.join(MANIFEST).display()))?;
            &from_manifest
        }
    };
    let expected = provenance.manifest(&read_modules(dir)?);
    if expected == shipped {
        return Ok(());
    }
    let have: BTreeSet<&str> = shipped.lines().collect();
    let differ: Vec<&str> = expected.lines().filter(|l| !have.contains(l)).collect();
    Err(format!(
        "{} does not match {}: expected {}",
        dir.display(),
        if sources.is_some() {
            "the kernel sources and the modules beside it"
        } else {
            "the modules beside it"
        },
        differ.join(", ")
    ))
}

/// The `[[package]]` entries of a `Cargo.lock`.
struct Lock(Vec<toml::Table>);

impl Lock {
    fn read(path: &Path) -> Result<Self, String> {
        let lock = toml_file(path)?;
        let packages = lock
            .get("package")
            .and_then(|p| p.as_array())
            .ok_or_else(|| format!("{}: no [[package]]", path.display()))?;
        Ok(Self(
            packages
                .iter()
                .filter_map(|p| p.as_table().cloned())
                .collect(),
        ))
    }

    /// Each version of package `name`, with its entry's text.
    fn entries<'a>(&'a self, name: &'a str) -> impl Iterator<Item = (String, String)> + 'a {
        self.0
            .iter()
            .filter(move |p| p.get("name").and_then(|n| n.as_str()) == Some(name))
            .map(|p| {
                let version = p.get("version").and_then(|v| v.as_str()).unwrap_or("");
                (
                    version.to_string(),
                    toml::Value::Table(p.clone()).to_string(),
                )
            })
    }

    /// The registry packages `roots` depend on, transitively (path packages are sources, hashed
    /// as files), keyed "name version", with their entries' text.
    fn closure(&self, roots: &BTreeSet<String>) -> BTreeMap<String, String> {
        let mut found = BTreeMap::new();
        let mut pending: Vec<(String, Option<String>)> =
            roots.iter().map(|r| (r.clone(), None)).collect();
        while let Some((name, version)) = pending.pop() {
            for p in &self.0 {
                let str_of = |key: &str| p.get(key).and_then(|v| v.as_str());
                if str_of("name") != Some(&name)
                    || version
                        .as_deref()
                        .is_some_and(|v| str_of("version") != Some(v))
                    || str_of("source").is_none()
                {
                    continue;
                }
                let key = format!("{name} {}", str_of("version").unwrap_or(""));
                if found.contains_key(&key) {
                    continue;
                }
                found.insert(key, toml::Value::Table(p.clone()).to_string());
                // "name", "name version" or "name version (source)".
                let deps = p.get("dependencies").and_then(|d| d.as_array());
                for dep in deps.into_iter().flatten().filter_map(|d| d.as_str()) {
                    let mut words = dep.split_whitespace();
                    if let Some(dep_name) = words.next() {
                        pending.push((dep_name.into(), words.next().map(str::to_string)));
                    }
                }
            }
        }
        found
    }
}

fn read(path: &Path) -> Result<Vec<u8>, String> {
    std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))
}

fn toml_file(path: &Path) -> Result<toml::Table, String> {
    let text = String::from_utf8(read(path)?).map_err(|e| format!("{}: {e}", path.display()))?;
    text.parse().map_err(|e| format!("{}: {e}", path.display()))
}

/// Every file below `dir`, recursively.
fn files_under(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let mut files = vec![];
    let mut pending = vec![dir.to_path_buf()];
    while let Some(d) = pending.pop() {
        let entries =
            std::fs::read_dir(&d).map_err(|e| format!("cannot list {}: {e}", d.display()))?;
        for entry in entries {
            let path = entry
                .map_err(|e| format!("cannot list {}: {e}", d.display()))?
                .path();
            if path.is_dir() {
                pending.push(path);
            } else {
                files.push(path);
            }
        }
    }
    Ok(files)
}
