//! (a) Mutations of the default scene: line and character edits of scenes/default.toml.

use crate::harness::{cases, check_scene, run_property, MAX_SCENE_BYTES};
use crate::values::{cap, odd_value, plain_number, standard_sets};
use proptest::prelude::*;
use wavetrace::DEFAULT_SCENE;

/// One edit of the scene text; indices are taken modulo the current length.
#[derive(Clone, Debug)]
enum Mutation {
    DeleteLine(prop::sample::Index),
    DuplicateLine(prop::sample::Index),
    SwapLines(prop::sample::Index, prop::sample::Index),
    MoveLine(prop::sample::Index, prop::sample::Index),
    /// Replaces the n-th number on a line.
    ReplaceNumber(prop::sample::Index, prop::sample::Index, String),
    /// Replaces what follows `=` on a line.
    ReplaceValue(prop::sample::Index, String),
    InsertLine(prop::sample::Index, String),
    DeleteChar(prop::sample::Index),
    InsertChar(prop::sample::Index, char),
    ReplaceChar(prop::sample::Index, char),
    Truncate(prop::sample::Index),
}

/// Lines worth inserting: schema headers and keys, unknown ones, duplicates, junk.
fn inserted_line() -> BoxedStrategy<String> {
    let headers = prop::sample::select(vec![
        "[render]",
        "[render.aa]",
        "[render.shadows]",
        "[render.dof]",
        "[camera]",
        "[background]",
        "[materials]",
        "[materials.white]",
        "[materials.new]",
        "[[lights]]",
        "[[objects]]",
        "[[materials]]",
        "[[camera]]",
        "[objects]",
        "[bogus]",
        "[render.aa.deeper]",
        "[]",
        "[[",
        "]]",
        "[a.\"b\".'c']",
    ])
    .prop_map(String::from);
    let keys = prop::sample::select(vec![
        "type",
        "width",
        "height",
        "max_depth",
        "seed",
        "mode",
        "samples",
        "eps",
        "min_level",
        "max_level",
        "share_corners",
        "probe",
        "position",
        "look_at",
        "up",
        "fov_y",
        "aperture",
        "focus_distance",
        "color",
        "specular",
        "shininess",
        "ior",
        "reflect_ratio",
        "corner",
        "edge_u",
        "edge_v",
        "radiance",
        "intensity",
        "center",
        "radius",
        "material",
        "file",
        "scale",
        "rotate_y",
        "translate",
        "unknown",
        "render",
        "camera",
        "objects",
        "\"\"",
        "a.b.c",
    ]);
    let assignment =
        (keys, prop_oneof![plain_number(), odd_value()]).prop_map(|(k, v): (&str, String)| format!("{k} = {v}"));
    prop_oneof![
        3 => headers,
        5 => assignment,
        1 => Just(String::new()),
        1 => Just("# comment".to_string()),
        1 => Just("=".to_string()),
        1 => Just("key =".to_string()),
        1 => Just("\u{feff}".to_string()),
        1 => "[ -~]{0,40}",
    ]
    .boxed()
}

/// Characters that matter to TOML, and some that do not belong at all.
fn interesting_char() -> BoxedStrategy<char> {
    prop_oneof![
        4 => prop::sample::select(vec![
            '[', ']', '{', '}', '=', '"', '\'', '.', ',', '#', '\n', '\r', '\t', ' ', '\\', '0', '9', '-', '+', 'e',
            '_', 'n', 'i',
        ]),
        1 => prop::sample::select(vec!['\u{0}', '\u{7f}', '\u{feff}', 'é', '\u{2028}', '\u{1F600}']),
        1 => any::<char>(),
    ]
    .boxed()
}

fn mutation() -> BoxedStrategy<Mutation> {
    use prop::sample::Index;
    let replacement = prop_oneof![2 => odd_value(), 1 => plain_number()].boxed();
    prop_oneof![
        3 => any::<Index>().prop_map(Mutation::DeleteLine),
        2 => any::<Index>().prop_map(Mutation::DuplicateLine),
        2 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
        1 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Mutation::MoveLine(a, b)),
        6 => (any::<Index>(), any::<Index>(), replacement.clone())
            .prop_map(|(l, n, v)| Mutation::ReplaceNumber(l, n, v)),
        3 => (any::<Index>(), replacement).prop_map(|(l, v)| Mutation::ReplaceValue(l, v)),
        3 => (any::<Index>(), inserted_line()).prop_map(|(l, s)| Mutation::InsertLine(l, s)),
        2 => any::<Index>().prop_map(Mutation::DeleteChar),
        2 => (any::<Index>(), interesting_char()).prop_map(|(i, c)| Mutation::InsertChar(i, c)),
        2 => (any::<Index>(), interesting_char()).prop_map(|(i, c)| Mutation::ReplaceChar(i, c)),
        1 => any::<Index>().prop_map(Mutation::Truncate),
    ]
    .boxed()
}

/// Byte ranges of the numbers on `line` (outside strings and comments, roughly).
fn numbers(line: &str) -> Vec<(usize, usize)> {
    let b = line.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'#' | b'"' => break,
            c if c.is_ascii_digit() || ((c == b'-' || c == b'+') && b.get(i + 1).is_some_and(u8::is_ascii_digit)) => {
                let start = i;
                i += 1;
                while i < b.len() && (b[i].is_ascii_alphanumeric() || matches!(b[i], b'.' | b'_' | b'-' | b'+')) {
                    i += 1;
                }
                out.push((start, i));
            }
            c if c.is_ascii_alphabetic() || c == b'_' => {
                // Skip a key or bare word: digits inside it are not numbers.
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                    i += 1;
                }
            }
            _ => i += 1,
        }
    }
    out
}

/// The char index `i` of `s` as a byte offset.
fn char_offset(s: &str, i: prop::sample::Index) -> usize {
    let n = s.chars().count();
    if n == 0 {
        return 0;
    }
    s.char_indices().nth(i.index(n)).map_or(s.len(), |(o, _)| o)
}

fn apply(text: &str, muts: &[Mutation]) -> String {
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    for m in muts {
        let n = lines.len();
        match m {
            Mutation::DeleteLine(i) if n > 0 => {
                lines.remove(i.index(n));
            }
            Mutation::DuplicateLine(i) if n > 0 => {
                let l = lines[i.index(n)].clone();
                lines.insert(i.index(n), l);
            }
            Mutation::SwapLines(a, b) if n > 0 => lines.swap(a.index(n), b.index(n)),
            Mutation::MoveLine(a, b) if n > 0 => {
                let l = lines.remove(a.index(n));
                lines.insert(b.index(n), l);
            }
            Mutation::ReplaceNumber(l, k, v) if n > 0 => {
                let line = &mut lines[l.index(n)];
                let nums = numbers(line);
                if !nums.is_empty() {
                    let (s, e) = nums[k.index(nums.len())];
                    line.replace_range(s..e, v);
                }
            }
            Mutation::ReplaceValue(l, v) if n > 0 => {
                let line = &mut lines[l.index(n)];
                if let Some(eq) = line.find('=') {
                    line.replace_range(eq + 1.., &format!(" {v}"));
                }
            }
            Mutation::InsertLine(l, s) => lines.insert(l.index(n + 1), s.clone()),
            Mutation::DeleteChar(_) | Mutation::InsertChar(..) | Mutation::ReplaceChar(..) | Mutation::Truncate(_) => {
                let mut t = lines.join("\n");
                match m {
                    Mutation::DeleteChar(i) if !t.is_empty() => {
                        t.remove(char_offset(&t, *i));
                    }
                    Mutation::InsertChar(i, c) => t.insert(char_offset(&t, *i), *c),
                    Mutation::ReplaceChar(i, c) if !t.is_empty() => {
                        let at = char_offset(&t, *i);
                        t.remove(at);
                        t.insert(at, *c);
                    }
                    Mutation::Truncate(i) => t.truncate(char_offset(&t, *i)),
                    _ => {}
                }
                lines = t.split('\n').map(String::from).collect();
            }
            _ => {}
        }
    }
    let mut text = lines.join("\n");
    text.push('\n');
    cap(text, MAX_SCENE_BYTES)
}

#[test]
fn mutated_default_scene() {
    let dir = tempfile::tempdir().unwrap();
    // One or two edits mostly (most scenes then still parse), up to eight now and then.
    let edits =
        prop_oneof![3 => prop::collection::vec(mutation(), 1..=2), 1 => prop::collection::vec(mutation(), 1..=8)];
    let strategy = (edits, standard_sets());
    let c = run_property("mutated_default_scene", strategy, |(muts, sets)| {
        check_scene(&apply(DEFAULT_SCENE, muts), dir.path(), sets)
    });
    if cases() >= 100 {
        assert!(c.loaded + c.rendered > 0, "no mutant loaded: the generator no longer reaches validation");
        assert!(c.rejected > 0, "every mutant loaded: the generator is too gentle");
    }
}
