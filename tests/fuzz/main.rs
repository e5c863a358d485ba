//! Hostile input (issue 6): property tests over generated scene TOML and OBJ text, and
//! the fixed regression cases they found; and (issue 16) the replay of the coverage-guided
//! fuzzers' corpus and findings ([`corpus`]) through their own checks ([`promise`], which
//! is fuzz/src/lib.rs).
//!
//! Five generators feed `wavetrace::scene::load`:
//! - `mutated_default_scene` ([`mutated`]): scenes/default.toml with random line and
//!   character mutations (delete, duplicate, swap, truncate, numbers replaced by extreme
//!   values, empty strings, deeply nested arrays and tables);
//! - `grammar_scene` ([`grammar`]): scenes built from the real schema (tables, keys, tagged
//!   types) plus unknown keys and values of the wrong type, with random `--set` overrides;
//! - `obj_mesh` ([`obj`]): OBJ text (v/vn/vt/f/l/p/o/g/s/usemtl/mtllib lines, out-of-range
//!   and negative indices, huge numbers, junk tokens, very long lines) written to a
//!   temporary folder and named by a mesh object;
//! - `xml_scene` ([`xml`]): edits of the Mitsuba XML scenes of scenes/import (lines,
//!   attribute values, unsupported plugins, entity definitions, deep nesting, include
//!   cycles, undefined `$` parameters);
//! - `ply_mesh` ([`ply`]): PLY headers and bodies (every format, counts up to 2^64 − 1,
//!   random binary), named by a mesh object, flat, smooth or emissive.
//!
//! [`values`] holds the value generators they share.
//!
//! Every case runs on its own thread under a watchdog and an allocation guard
//! ([`harness`]) and must end, within [`harness::HANG_LIMIT`], in a scene or an
//! `Error::Input` whose message names the file and a place in it: no panic, no hang, no
//! more than [`harness::LOAD_MEMORY`] bytes allocated at once. A scene that loads must
//! have a finite camera; when it is small it is rendered at 4×4 and its pixels must be
//! finite. These rules are [`promise::check_source`], the fuzz targets' own.
//!
//! Failures this fuzzing found that src/ does not fix yet are listed in
//! [`harness::KNOWN`]: a case that hits one is counted and reported, not failed
//! (`WAVETRACE_FUZZ_STRICT=1` fails it), and each has a test with a minimal input in
//! [`regressions`], ignored in the builds where it fails, next to the fixed cases.
//!
//! Cases per generator: `WAVETRACE_FUZZ_CASES` (default 200); `PROPTEST_RNG_SEED` fixes
//! the seed. A long run:
//! `WAVETRACE_FUZZ_CASES=20000 cargo test --release --test fuzz -- --nocapture`.

mod harness;
mod values;

mod corpus;
/// The promise each input is checked against, shared with the libFuzzer targets.
#[path = "../../fuzz/src/lib.rs"]
#[allow(dead_code)]
mod promise;

mod grammar;
mod mutated;
mod obj;
mod ply;
mod xml;

mod regressions;
