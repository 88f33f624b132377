//! Build id: a SHA-256 of the sources (`src/`, `build.rs`, `Cargo.toml`, `Cargo.lock`),
//! given to the crate as `DETUNE_BUILD_ID` (16 hex digits). A sweep checkpoint records it
//! and is resumed or merged only by the same build (`src/frequency/checkpoint.rs`): the
//! crate's version is the same for every commit, a checkpoint's cases are not. Hashing the
//! files, not asking git, makes it work from a source archive too.

use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            files(&p, out);
        } else {
            out.push(p);
        }
    }
}

fn main() {
    let root = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let mut list = Vec::new();
    files(&root.join("src"), &mut list);
    for f in ["build.rs", "Cargo.toml", "Cargo.lock"] {
        list.push(root.join(f));
    }
    list.sort();
    let mut h = Sha256::new();
    for p in &list {
        let rel = p.strip_prefix(&root).unwrap_or(p);
        // path separators as `/`, so the id is the same on every platform
        let name = rel.to_string_lossy().replace('\\', "/");
        h.update((name.len() as u64).to_le_bytes());
        h.update(name.as_bytes());
        let bytes = std::fs::read(p).unwrap_or_default();
        h.update((bytes.len() as u64).to_le_bytes());
        h.update(&bytes);
    }
    let hex: String = h.finalize()[..8]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    println!("cargo:rustc-env=DETUNE_BUILD_ID={hex}");
    println!("cargo:rerun-if-changed=src");
    for f in ["build.rs", "Cargo.toml", "Cargo.lock"] {
        println!("cargo:rerun-if-changed={f}");
    }
}
