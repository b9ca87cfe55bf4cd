//! No module cycles (issue 23): within each module, its submodules use each other in one
//! direction only, so that a pass, a record layout or a helper can be read (and changed) without
//! the modules that use it.
//!
//! A module's uses are every `crate::`, `super::` and `self::` path in its file (`use` trees,
//! types, calls), outside `#[cfg(test)]` items, resolved to the deepest module that the path
//! names. A use from `a::b::c` of `a::d::e` is a use of `a::d` by `a::b`: the check lifts each use
//! to the two siblings below the modules' common ancestor. A module's use of its own ancestors or
//! descendants (a `mod.rs` re-exporting its children, a child using what its parent defines) is
//! not a sibling's and is not counted. Every strongly connected group of more than one sibling is
//! a cycle.
//!
//! `cargo test -p gi-tests --test module_cycles` checks `gi-shared` (`shared/src`, none allowed)
//! and `gi-host` (`host/src`: none in `host/src/gi`; the older ones elsewhere are listed in
//! [`KNOWN_HOST_CYCLES`] and may not grow), and prints every cycle it finds.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use syn::visit::Visit;

/// A module path below the crate root (`["gi", "renderer"]`; empty for the root).
type ModulePath = Vec<String>;

/// The crate's modules: the file of each, from `lib.rs` down through `mod` declarations.
fn modules(src: &Path) -> BTreeMap<ModulePath, PathBuf> {
    let mut found = BTreeMap::new();
    let mut stack = vec![(Vec::new(), src.join("lib.rs"))];
    while let Some((path, file)) = stack.pop() {
        let text = std::fs::read_to_string(&file)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", file.display()));
        let syntax = syn::parse_file(&text).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        // `a.rs` and `a/mod.rs` keep their children in `a/`; `lib.rs` in `src/`.
        let dir = match file.file_name().and_then(|n| n.to_str()) {
            Some("lib.rs") | Some("mod.rs") => file.parent().unwrap().to_path_buf(),
            _ => file.with_extension(""),
        };
        for item in &syntax.items {
            if let syn::Item::Mod(m) = item
                && m.content.is_none()
                && !is_test_only(&m.attrs)
            {
                let name = m.ident.to_string();
                let child = [
                    dir.join(format!("{name}.rs")),
                    dir.join(&name).join("mod.rs"),
                ]
                .into_iter()
                .find(|p| p.exists())
                .unwrap_or_else(|| panic!("{}: no file for `mod {name}`", file.display()));
                let mut child_path = path.clone();
                child_path.push(name);
                stack.push((child_path, child));
            }
        }
        found.insert(path, file);
    }
    found
}

/// Whether `attrs` hold `#[cfg(test)]`.
fn is_test_only(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("cfg")
            && a.parse_args::<syn::Path>()
                .is_ok_and(|p| p.is_ident("test"))
    })
}

/// Collects the paths a file names, relative to its module, outside test-only items.
#[derive(Default)]
struct Uses {
    paths: Vec<Vec<String>>,
}

impl Uses {
    fn tree(&mut self, prefix: &mut Vec<String>, tree: &syn::UseTree) {
        match tree {
            syn::UseTree::Path(p) => {
                prefix.push(p.ident.to_string());
                self.tree(prefix, &p.tree);
                prefix.pop();
            }
            syn::UseTree::Name(n) => {
                let mut p = prefix.clone();
                if n.ident != "self" {
                    p.push(n.ident.to_string());
                }
                self.paths.push(p);
            }
            syn::UseTree::Rename(r) => {
                let mut p = prefix.clone();
                p.push(r.ident.to_string());
                self.paths.push(p);
            }
            syn::UseTree::Glob(_) => self.paths.push(prefix.clone()),
            syn::UseTree::Group(g) => {
                for t in &g.items {
                    self.tree(prefix, t);
                }
            }
        }
    }
}

impl<'ast> Visit<'ast> for Uses {
    fn visit_item(&mut self, item: &'ast syn::Item) {
        let attrs = match item {
            syn::Item::Mod(m) => &m.attrs,
            syn::Item::Fn(f) => &f.attrs,
            syn::Item::Impl(i) => &i.attrs,
            syn::Item::Use(u) => &u.attrs,
            syn::Item::Const(c) => &c.attrs,
            syn::Item::Struct(s) => &s.attrs,
            _ => return syn::visit::visit_item(self, item),
        };
        if !is_test_only(attrs) {
            syn::visit::visit_item(self, item);
        }
    }

    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        self.tree(&mut Vec::new(), &u.tree);
    }

    fn visit_path(&mut self, path: &'ast syn::Path) {
        self.paths
            .push(path.segments.iter().map(|s| s.ident.to_string()).collect());
        syn::visit::visit_path(self, path);
    }

    fn visit_macro(&mut self, mac: &'ast syn::Macro) {
        // Paths inside macro calls (`bindings!`, `format!` arguments) are tokens: read the ones
        // that start at the crate or a parent.
        self.tokens(mac.tokens.clone());
        syn::visit::visit_macro(self, mac);
    }
}

impl Uses {
    fn tokens(&mut self, tokens: proc_macro2::TokenStream) {
        let tokens: Vec<proc_macro2::TokenTree> = tokens.into_iter().collect();
        for (i, t) in tokens.iter().enumerate() {
            match t {
                proc_macro2::TokenTree::Group(g) => self.tokens(g.stream()),
                proc_macro2::TokenTree::Ident(id) if id == "crate" || id == "super" => {
                    let mut path = vec![id.to_string()];
                    let mut j = i + 1;
                    while let [
                        proc_macro2::TokenTree::Punct(a),
                        proc_macro2::TokenTree::Punct(b),
                        proc_macro2::TokenTree::Ident(seg),
                        ..,
                    ] = &tokens[j.min(tokens.len())..]
                        && a.as_char() == ':'
                        && b.as_char() == ':'
                    {
                        path.push(seg.to_string());
                        j += 3;
                    }
                    self.paths.push(path);
                }
                _ => {}
            }
        }
    }
}

/// `path`, named from module `from`, as a path from the crate root; `None` for a path that starts
/// elsewhere (another crate, a local name).
fn absolute(from: &ModulePath, path: &[String]) -> Option<Vec<String>> {
    let mut base = from.clone();
    let mut rest = path;
    match rest.first().map(String::as_str) {
        Some("crate") => {
            base.clear();
            rest = &rest[1..];
        }
        Some("super") | Some("self") => {
            while let Some(s) = rest.first() {
                match s.as_str() {
                    "super" => {
                        base.pop()?;
                    }
                    "self" => {}
                    _ => break,
                }
                rest = &rest[1..];
            }
        }
        _ => return None,
    }
    base.extend(rest.iter().cloned());
    Some(base)
}

/// The sibling-level uses of the crate at `src`: per parent module, its children's uses of each
/// other.
fn sibling_uses(src: &Path) -> BTreeMap<ModulePath, BTreeSet<(String, String)>> {
    let modules = modules(src);
    let mut out: BTreeMap<ModulePath, BTreeSet<(String, String)>> = BTreeMap::new();
    for (from, file) in &modules {
        let syntax = syn::parse_file(&std::fs::read_to_string(file).unwrap()).unwrap();
        let mut uses = Uses::default();
        uses.visit_file(&syntax);
        for path in &uses.paths {
            let Some(abs) = absolute(from, path) else {
                continue;
            };
            // The deepest module the path names.
            let Some(to) = (0..=abs.len())
                .rev()
                .map(|n| abs[..n].to_vec())
                .find(|p| modules.contains_key(p))
            else {
                continue;
            };
            let common = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
            if common == from.len() || common == to.len() {
                continue; // an ancestor or a descendant
            }
            out.entry(from[..common].to_vec())
                .or_default()
                .insert((from[common].clone(), to[common].clone()));
        }
    }
    out
}

/// A cycle: the parent module, the siblings that use each other in a circle, and its uses.
struct Cycle {
    parent: String,
    members: BTreeSet<String>,
    uses: String,
}

/// The cycles among each parent's children: strongly connected groups of more than one.
fn cycles(src: &Path) -> Vec<Cycle> {
    let mut found = Vec::new();
    for (parent, edges) in sibling_uses(src) {
        let nodes: BTreeSet<&String> = edges.iter().flat_map(|(a, b)| [a, b]).collect();
        let reach = |start: &String| {
            let mut seen = BTreeSet::from([start.clone()]);
            let mut stack = vec![start.clone()];
            while let Some(n) = stack.pop() {
                for (_, b) in edges.iter().filter(|(a, _)| *a == n) {
                    if seen.insert(b.clone()) {
                        stack.push(b.clone());
                    }
                }
            }
            seen
        };
        let mut grouped = BTreeSet::new();
        for &n in &nodes {
            if grouped.contains(n) {
                continue;
            }
            let group: BTreeSet<String> = reach(n)
                .into_iter()
                .filter(|m| reach(m).contains(n))
                .collect();
            grouped.extend(group.iter().cloned());
            if group.len() > 1 {
                let uses: Vec<String> = edges
                    .iter()
                    .filter(|(a, b)| group.contains(a) && group.contains(b))
                    .map(|(a, b)| format!("{a} → {b}"))
                    .collect();
                found.push(Cycle {
                    parent: if parent.is_empty() {
                        "crate".to_string()
                    } else {
                        parent.join("::")
                    },
                    members: group,
                    uses: uses.join(", "),
                });
            }
        }
    }
    found
}

/// Cycles of `gi-host` outside `host/src/gi` that predate the check: (parent, members). A new
/// cycle, or a new member of one of these, fails the test; removing one is welcome.
const KNOWN_HOST_CYCLES: [(&str, &[&str]); 5] = [
    ("crate", &["engine", "gi"]),
    ("crate", &["kernels", "vulkan"]),
    ("bench", &["plot", "report"]),
    ("scene", &["bvh", "gpu_data"]),
    (
        "vulkan",
        &["context", "image", "memory", "pipeline", "split_buffer"],
    ),
];

#[test]
fn no_module_uses_a_sibling_that_uses_it_back() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut failures = Vec::new();
    for krate in ["shared", "host"] {
        let found = cycles(&root.join(krate).join("src"));
        println!("{krate}/src: {} module cycles", found.len());
        for c in &found {
            let known = krate == "host"
                && KNOWN_HOST_CYCLES.iter().any(|(parent, members)| {
                    *parent == c.parent && c.members.iter().all(|m| members.contains(&m.as_str()))
                });
            println!(
                "  in `{}`: {}{}",
                c.parent,
                c.uses,
                if known { " (known)" } else { "" }
            );
            if !known {
                failures.push(format!("{krate}/src, in `{}`: {}", c.parent, c.uses));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "module cycles:\n{}",
        failures.join("\n")
    );
}

#[test]
fn the_check_finds_a_cycle_and_ignores_parents() {
    let dir = std::env::temp_dir().join(format!("gi-module-cycles-{}", std::process::id()));
    let src = dir.join("src");
    std::fs::create_dir_all(src.join("p")).unwrap();
    let write = |name: &str, text: &str| std::fs::write(src.join(name), text).unwrap();
    write("lib.rs", "mod p;\npub struct Root;\n");
    write(
        "p/mod.rs",
        "mod a;\nmod b;\nmod c;\npub use a::A;\npub struct P;\n",
    );
    write("p/a.rs", "use super::b::B;\npub struct A(B);\n");
    write(
        "p/b.rs",
        "pub struct B;\nfn f() { let _ = crate::p::a::A(B); }\n",
    );
    write(
        "p/c.rs",
        "use super::P;\nuse crate::Root;\n#[cfg(test)]\nmod tests { use super::super::a::A; }\n",
    );
    let found: Vec<(String, String)> = cycles(&src)
        .into_iter()
        .map(|c| (c.parent, c.uses))
        .collect();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(found, vec![("p".to_string(), "a → b, b → a".to_string())]);
}
