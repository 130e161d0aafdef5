//! Mutated scene files (proptest): loading and building never panics, and every error names
//! the file and a line (and, past the syntax, the field).
//!
//! The mutations start from `scenes/reference.ron` (every field and every shape): numbers
//! replaced by extreme ones (0, −1, 10^−30, 10^30, 10^300, NaN, ∞, 2^32, 2^64, ...), strings by
//! empty ones or paths to a device or a missing file, words swapped, tokens deleted or
//! duplicated. Each mutated file is written to a temporary folder holding the reference's mesh
//! and loaded with `SceneFile::load_and_build`.
#![cfg(feature = "scene")]

use proptest::prelude::*;
use rapier_sph::scene_file::{SceneError, SceneFile};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn reference() -> &'static str {
    static TEXT: OnceLock<String> = OnceLock::new();
    TEXT.get_or_init(|| {
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/reference.ron"))
            .unwrap()
    })
}

/// A folder with the reference's mesh, for the mutated files.
fn folder() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir =
            std::env::temp_dir().join(format!("rapier_sph_scene_fuzz_{}", std::process::id()));
        std::fs::create_dir_all(dir.join("meshes")).unwrap();
        std::fs::copy(
            concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/meshes/ramp.obj"),
            dir.join("meshes/ramp.obj"),
        )
        .unwrap();
        dir
    })
}

/// Byte ranges of the reference's tokens outside comments: numbers, words, strings.
fn tokens() -> &'static [(usize, usize, u8)] {
    static TOKENS: OnceLock<Vec<(usize, usize, u8)>> = OnceLock::new();
    TOKENS.get_or_init(|| {
        let b = reference().as_bytes();
        let mut out = Vec::new();
        let mut i = 0;
        while i < b.len() {
            let c = b[i];
            if b[i..].starts_with(b"//") {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            } else if c == b'"' {
                let s = i;
                i += 1;
                while i < b.len() && b[i] != b'"' {
                    i += 1;
                }
                i += 1;
                out.push((s, i, b's'));
            } else if c.is_ascii_digit() || c == b'-' {
                let s = i;
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b"-+.".contains(&b[i])) {
                    i += 1;
                }
                out.push((s, i, b'n'));
            } else if c.is_ascii_alphabetic() || c == b'_' {
                let s = i;
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                    i += 1;
                }
                out.push((s, i, b'w'));
            } else {
                if b"()[],:".contains(&c) {
                    out.push((i, i + 1, b'p'));
                }
                i += 1;
            }
        }
        out
    })
}

/// The tokens that are values (numbers, words, strings), not punctuation.
fn values() -> &'static [(usize, usize, u8)] {
    static VALUES: OnceLock<Vec<(usize, usize, u8)>> = OnceLock::new();
    VALUES.get_or_init(|| tokens().iter().copied().filter(|t| t.2 != b'p').collect())
}

const NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1e-30",
    "1e30",
    "1e300",
    "NaN",
    "inf",
    "-inf",
    "4294967296",
    "18446744073709551616",
    "1e5",
    "0.5",
    "3",
    "-0.0",
    "2048",
    "65537",
];
const STRINGS: &[&str] = &[
    "\"\"",
    "\"/dev/zero\"",
    "\"meshes/missing.obj\"",
    "\"meshes\"",
    "\"ground\"",
    "\"floor\"",
];
const WORDS: &[&str] = &[
    "Pbf", "Wcsph", "Clavet", "Dynamic", "Paper", "Square", "Sphere", "TriMesh", "Compound",
    "Some", "None", "true", "false", "Linear",
];

/// A mutation: which token (a fraction of the list) and what to do with it.
#[derive(Clone, Debug)]
enum Mutation {
    Replace(f64, usize),
    Delete(f64),
    Duplicate(f64),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        6 => (0.0..1.0f64, any::<usize>()).prop_map(|(a, k)| Mutation::Replace(a, k)),
        1 => (0.0..1.0f64).prop_map(Mutation::Delete),
        1 => (0.0..1.0f64).prop_map(Mutation::Duplicate),
    ]
}

/// The reference with `mutations` applied (tokens chosen in the original; applied from the
/// last to the first so the ranges stay valid).
fn mutate(mutations: &[Mutation]) -> String {
    let toks = tokens();
    let mut edits: Vec<(usize, usize, String)> = mutations
        .iter()
        .map(|m| {
            let pick = |a: f64| toks[((a * toks.len() as f64) as usize).min(toks.len() - 1)];
            let values = values();
            match *m {
                Mutation::Replace(a, k) => {
                    let (s, e, kind) =
                        values[((a * values.len() as f64) as usize).min(values.len() - 1)];
                    let list = match kind {
                        b'n' => NUMBERS,
                        b's' => STRINGS,
                        b'w' => WORDS,
                        _ => NUMBERS,
                    };
                    (s, e, list[k % list.len()].to_string())
                }
                Mutation::Delete(a) => {
                    let (s, e, _) = pick(a);
                    (s, e, String::new())
                }
                Mutation::Duplicate(a) => {
                    let (s, e, _) = pick(a);
                    (s, e, reference()[s..e].repeat(2))
                }
            }
        })
        .collect();
    edits.sort_by_key(|e| std::cmp::Reverse(e.0));
    edits.dedup_by_key(|e| e.0);
    let mut text = reference().to_string();
    let mut last = usize::MAX;
    for (s, e, with) in edits {
        if e > last {
            continue; // overlapping
        }
        text.replace_range(s..e, &with);
        last = s;
    }
    text
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn mutated_scenes_never_panic_and_errors_are_located(
        mutations in prop::collection::vec(mutation(), 1..4),
        case in any::<u64>(),
    ) {
        let text = mutate(&mutations);
        let path = folder().join(format!("scene_{case}.ron"));
        std::fs::write(&path, &text).unwrap();
        let result = SceneFile::load_and_build(&path);
        std::fs::remove_file(&path).ok();
        match result {
            Ok(_) => {}
            Err(e @ SceneError::Parse { .. }) => {
                let SceneError::Parse { path: p, line, .. } = &e else { unreachable!() };
                prop_assert_eq!(p, &path);
                prop_assert!(*line >= 1 && *line <= text.lines().count() + 1, "{}", e);
                let shown = e.to_string();
                let prefix = format!("{}:{line}:", path.display());
                prop_assert!(shown.starts_with(&prefix), "{}", shown);
            }
            Err(e) => prop_assert!(false, "an error without a line: {e} ({mutations:?})"),
        }
    }
}

/// The mutations do something: most of the reference's values can be broken.
#[test]
fn the_unmutated_reference_builds() {
    let path = folder().join("reference.ron");
    std::fs::write(&path, reference()).unwrap();
    SceneFile::load_and_build(&path).unwrap();
}

/// Counts what many mutations give and shows a few errors (prints; `--ignored --nocapture`).
#[test]
#[ignore = "a measurement, not a check: prints what many mutations give (run with --ignored --nocapture)"]
fn mutation_outcomes() {
    use rand::{Rng, SeedableRng};
    let n: usize = std::env::var("N").map_or(2000, |v| v.parse().unwrap());
    let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
    let (mut ok, mut located, mut other) = (0, 0, 0);
    let mut samples = Vec::new();
    for case in 0..n {
        let mutations: Vec<Mutation> = (0..rng.random_range(1..4))
            .map(|_| match rng.random_range(0..8) {
                0 => Mutation::Delete(rng.random()),
                1 => Mutation::Duplicate(rng.random()),
                _ => Mutation::Replace(rng.random(), rng.random::<u32>() as usize),
            })
            .collect();
        let text = mutate(&mutations);
        let path = folder().join(format!("outcome_{case}.ron"));
        std::fs::write(&path, &text).unwrap();
        match SceneFile::load_and_build(&path) {
            Ok(_) => ok += 1,
            Err(e @ SceneError::Parse { .. }) => {
                located += 1;
                if samples.len() < 40 && rng.random_range(0..10) == 0 {
                    samples.push(e.to_string());
                }
            }
            Err(e) => {
                other += 1;
                samples.push(format!("NOT LOCATED: {e}"));
            }
        }
        std::fs::remove_file(&path).ok();
    }
    println!("{n} mutated scenes: {ok} built, {located} located errors, {other} other errors");
    for s in samples {
        println!("  {s}");
    }
}
