//! A kernel's set-0 bindings read from its SPIR-V: the one declaration of what a pass binds.
//!
//! rust-gpu emits SPIR-V 1.5, whose `OpEntryPoint` lists every global the entry point uses, each
//! with its `OpName` (the kernel parameter's name), `DescriptorSet`, `Binding` and, on buffers the
//! kernel only reads, `NonWritable`; a storage image is written when the module has an
//! `OpImageWrite` to a value loaded from its variable (rust-gpu inlines every call into the entry
//! point; a function that still calls another counts the images it loads as written). The test is
//! per variable, not per entry point, because rust-gpu gives the same parameter of two kernels
//! (same set, binding and type) one variable, and the validation layer's synchronization checks
//! then count a kernel that only reads it as writing it too. A parameter the kernel never uses is
//! compiled away and has no binding. The host declares the same bindings by name ([`crate::bindings!`]) and
//! [`check_declared`] compares the two when the pipeline is created, so a swapped pair, a missing
//! binding or a wrong kind is an error naming the kernel and the binding, not a silent misbind.

use super::BindingKind;
use super::bindings::DeclaredBinding;
use std::collections::HashMap;

/// One set-0 binding of a kernel, as its SPIR-V declares it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KernelBinding {
    /// The binding number.
    pub binding: u32,
    /// The kernel parameter's name.
    pub name: String,
    /// What it holds.
    pub kind: BindingKind,
    /// Whether the kernel may write it (buffers without `NonWritable`; storage images it
    /// `OpImageWrite`s).
    pub writes: bool,
}

// SPIR-V opcodes, decorations and storage classes read here (SPIR-V 1.5 specification, §3).
const OP_NAME: u32 = 5;
const OP_ENTRY_POINT: u32 = 15;
const OP_FUNCTION: u32 = 54;
const OP_FUNCTION_END: u32 = 56;
const OP_FUNCTION_CALL: u32 = 57;
const OP_LOAD: u32 = 61;
const OP_IMAGE_WRITE: u32 = 99;
const OP_TYPE_IMAGE: u32 = 25;
const OP_TYPE_SAMPLED_IMAGE: u32 = 27;
const OP_TYPE_ARRAY: u32 = 28;
const OP_TYPE_RUNTIME_ARRAY: u32 = 29;
const OP_TYPE_POINTER: u32 = 32;
const OP_VARIABLE: u32 = 59;
const OP_DECORATE: u32 = 71;
const OP_TYPE_ACCELERATION_STRUCTURE: u32 = 5341;
const DECORATION_NON_WRITABLE: u32 = 24;
const DECORATION_BINDING: u32 = 33;
const DECORATION_DESCRIPTOR_SET: u32 = 34;
const STORAGE_CLASS_STORAGE_BUFFER: u32 = 12;
/// `OpTypeImage`'s "Sampled" operand of an image read and written without a sampler.
const IMAGE_STORAGE: u32 = 2;

/// The set-0 bindings of every entry point of a module, by entry point, in binding order. A
/// malformed module yields what could be read.
pub fn set0_bindings(words: &[u32]) -> HashMap<String, Vec<KernelBinding>> {
    let mut names: HashMap<u32, String> = HashMap::new();
    let mut decorations: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
    let mut pointers: HashMap<u32, (u32, u32)> = HashMap::new();
    let mut types: HashMap<u32, (u32, Vec<u32>)> = HashMap::new();
    let mut variables: HashMap<u32, u32> = HashMap::new();
    let mut entries: Vec<(String, Vec<u32>)> = vec![];
    // The variables images are written through, and those loaded in a function that calls.
    let mut written: Vec<u32> = vec![];
    let mut calls = false;
    let mut loads: HashMap<u32, u32> = HashMap::new();
    let mut i = 5; // past the header
    while i < words.len() {
        let count = (words[i] >> 16) as usize;
        if count == 0 || i + count > words.len() {
            break;
        }
        let op = words[i] & 0xffff;
        let args = &words[i + 1..i + count];
        match op {
            OP_NAME if !args.is_empty() => {
                names.insert(args[0], string(&args[1..]).0);
            }
            OP_DECORATE if args.len() >= 2 => decorations
                .entry(args[0])
                .or_default()
                .push((args[1], args.get(2).copied().unwrap_or(0))),
            OP_ENTRY_POINT if args.len() >= 2 => {
                let (name, used) = string(&args[2..]);
                entries.push((name, args[2 + used..].to_vec()));
            }
            OP_FUNCTION => {
                calls = false;
                loads.clear();
            }
            OP_FUNCTION_CALL => calls = true,
            OP_LOAD if args.len() >= 3 => {
                loads.insert(args[1], args[2]);
            }
            OP_FUNCTION_END if calls => written.extend(loads.values()),
            OP_IMAGE_WRITE if !args.is_empty() => written.extend(loads.get(&args[0])),
            OP_TYPE_POINTER if args.len() >= 3 => {
                pointers.insert(args[0], (args[1], args[2]));
            }
            OP_VARIABLE if args.len() >= 2 => {
                variables.insert(args[1], args[0]);
            }
            OP_TYPE_IMAGE
            | OP_TYPE_SAMPLED_IMAGE
            | OP_TYPE_ARRAY
            | OP_TYPE_RUNTIME_ARRAY
            | OP_TYPE_ACCELERATION_STRUCTURE
                if !args.is_empty() =>
            {
                types.insert(args[0], (op, args[1..].to_vec()));
            }
            _ => {}
        }
        i += count;
    }
    let decoration = |id: u32, which: u32| {
        decorations
            .get(&id)
            .and_then(|d| d.iter().find(|(k, _)| *k == which).map(|(_, v)| *v))
    };
    let kind_of = |variable: u32| -> Option<BindingKind> {
        let &(class, pointee) = pointers.get(variables.get(&variable)?)?;
        if class == STORAGE_CLASS_STORAGE_BUFFER {
            return Some(match types.get(&pointee) {
                Some((OP_TYPE_RUNTIME_ARRAY | OP_TYPE_ARRAY, _)) => BindingKind::SplitBuffer,
                _ => BindingKind::StorageBuffer,
            });
        }
        match types.get(&pointee)? {
            (OP_TYPE_IMAGE, operands) => Some(if operands.get(5) == Some(&IMAGE_STORAGE) {
                BindingKind::StorageImage
            } else {
                BindingKind::SampledImage
            }),
            (OP_TYPE_ACCELERATION_STRUCTURE, _) => Some(BindingKind::AccelerationStructure),
            _ => None,
        }
    };
    entries
        .into_iter()
        .map(|(entry, interface)| {
            let mut bindings: Vec<KernelBinding> = interface
                .iter()
                .filter(|&&v| decoration(v, DECORATION_DESCRIPTOR_SET) == Some(0))
                .filter_map(|&v| {
                    let kind = kind_of(v)?;
                    Some(KernelBinding {
                        binding: decoration(v, DECORATION_BINDING)?,
                        name: names.get(&v).cloned().unwrap_or_default(),
                        kind,
                        writes: match kind {
                            BindingKind::StorageImage => written.contains(&v),
                            _ => decoration(v, DECORATION_NON_WRITABLE).is_none(),
                        },
                    })
                })
                .collect();
            bindings.sort_by_key(|b| b.binding);
            (entry, bindings)
        })
        .collect()
}

/// A nul-terminated SPIR-V literal string and the words it takes.
fn string(words: &[u32]) -> (String, usize) {
    let bytes: Vec<u8> = words
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .take_while(|&b| b != 0)
        .collect();
    (
        String::from_utf8_lossy(&bytes).into_owned(),
        bytes.len() / 4 + 1,
    )
}

/// Whether the host's `declared` bindings are the kernel's: the same names, in binding order,
/// with the same kinds. The error names the binding at fault and what is wrong with it.
pub fn check_declared(
    kernel: &[KernelBinding],
    declared: &[DeclaredBinding],
) -> Result<(), String> {
    let in_kernel = |name: &str| kernel.iter().find(|b| b.name == name);
    for (i, d) in declared.iter().enumerate() {
        let Some(k) = in_kernel(d.name) else {
            return Err(format!(
                "the host binds `{}`, which the kernel does not declare in set 0 (or never uses)",
                d.name
            ));
        };
        if k.kind != d.kind {
            return Err(format!(
                "binding {} `{}` is a {} in the kernel, the host binds a {}",
                k.binding,
                k.name,
                kind_name(k.kind),
                kind_name(d.kind)
            ));
        }
        if kernel.get(i).map(|b| b.name.as_str()) != Some(d.name) {
            let expected = &kernel[i.min(kernel.len() - 1)];
            return Err(format!(
                "binding {} is `{}` in the kernel, the host declares `{}` in its place (swapped?)",
                expected.binding, expected.name, d.name
            ));
        }
    }
    if let Some(missing) = kernel.get(declared.len()) {
        return Err(format!(
            "binding {} `{}` ({}) is not bound by the host",
            missing.binding,
            missing.name,
            kind_name(missing.kind)
        ));
    }
    Ok(())
}

fn kind_name(kind: BindingKind) -> &'static str {
    match kind {
        BindingKind::StorageBuffer => "storage buffer",
        BindingKind::SplitBuffer => "split storage buffer",
        BindingKind::AccelerationStructure => "acceleration structure",
        BindingKind::StorageImage => "storage image",
        BindingKind::SampledImage => "sampled image",
        BindingKind::Textures(_) => "texture array",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::{KernelVariant, common_spirv_words};

    fn declared(items: &[(&'static str, BindingKind)]) -> Vec<DeclaredBinding> {
        items
            .iter()
            .map(|&(name, kind)| DeclaredBinding { name, kind })
            .collect()
    }

    #[test]
    fn every_kernel_has_its_parameters_as_bindings() {
        let all = set0_bindings(&common_spirv_words());
        assert_eq!(all.len(), KernelVariant::Software.entry_points().len());
        let trace = &all["trace_rays::trace_rays"];
        let names: Vec<_> = trace
            .iter()
            .map(|b| (b.binding, b.name.as_str(), b.kind, b.writes))
            .collect();
        assert_eq!(
            names,
            [
                (0, "rays", BindingKind::StorageBuffer, false),
                (1, "hits", BindingKind::StorageBuffer, true)
            ]
        );
        let gbuffer = &all["gbuffer::gbuffer"];
        assert_eq!(gbuffer[1].name, "depth");
        assert_eq!(gbuffer[1].kind, BindingKind::StorageImage);
        // The G-buffer pass writes its images; a pass that reads them does not.
        assert!(gbuffer[1..8].iter().all(|b| b.writes), "{gbuffer:?}");
        let interpolate = &all["screen_probes::interpolate::interpolate_screen_probes"];
        let depth = interpolate.iter().find(|b| b.name == "depth").unwrap();
        assert!(!depth.writes, "{interpolate:?}");
        let import = &all["gbuffer_import::import_gbuffer"];
        assert_eq!(import[1].name, "engine_depth");
        assert_eq!(import[1].kind, BindingKind::SampledImage);
        // Every kernel's bindings are named, and no name or number repeats.
        for (entry, bindings) in &all {
            for (i, b) in bindings.iter().enumerate() {
                assert!(!b.name.is_empty(), "{entry}: binding {} unnamed", b.binding);
                assert!(
                    bindings[..i]
                        .iter()
                        .all(|a| a.name != b.name && a.binding != b.binding),
                    "{entry}: {b:?} repeats"
                );
            }
        }
    }

    #[test]
    fn both_modules_give_a_tracing_kernel_the_same_bindings() {
        let common = set0_bindings(&common_spirv_words());
        let ray_query = set0_bindings(&KernelVariant::RayQuery.tracing_spirv_words());
        for (entry, bindings) in &ray_query {
            assert_eq!(Some(bindings), common.get(entry), "{entry}");
        }
    }

    #[test]
    fn a_malformed_module_yields_no_bindings_and_no_panic() {
        assert!(set0_bindings(&[]).is_empty());
        let words = common_spirv_words();
        let _ = set0_bindings(&words[..words.len() / 3]);
    }

    #[test]
    fn the_declaration_must_match_name_order_and_kind() {
        let kernel = &set0_bindings(&common_spirv_words())["trace_rays::trace_rays"];
        let buffer = BindingKind::StorageBuffer;
        assert_eq!(
            check_declared(kernel, &declared(&[("rays", buffer), ("hits", buffer)])),
            Ok(())
        );
        assert_eq!(
            check_declared(kernel, &declared(&[("hits", buffer), ("rays", buffer)])),
            Err(
                "binding 0 is `rays` in the kernel, the host declares `hits` in its place \
                 (swapped?)"
                    .into()
            )
        );
        assert_eq!(
            check_declared(kernel, &declared(&[("rays", buffer)])),
            Err("binding 1 `hits` (storage buffer) is not bound by the host".into())
        );
        assert_eq!(
            check_declared(
                kernel,
                &declared(&[("rays", buffer), ("hits", BindingKind::StorageImage)])
            ),
            Err(
                "binding 1 `hits` is a storage buffer in the kernel, the host binds a storage \
                 image"
                    .into()
            )
        );
        assert_eq!(
            check_declared(
                kernel,
                &declared(&[("rays", buffer), ("hits", buffer), ("extra", buffer)])
            ),
            Err(
                "the host binds `extra`, which the kernel does not declare in set 0 (or never \
                 uses)"
                    .into()
            )
        );
    }
}
