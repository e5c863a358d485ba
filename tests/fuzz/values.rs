//! Value generators shared by the scene generators: extreme numbers, values of the wrong
//! kind, plausible numbers, TOML quoting, and the length cap and `--set` lists.

use crate::harness::TINY;
use proptest::prelude::*;

/// Numbers that break things: overflow for f32, u32 and i64, signed zero, NaN, infinity,
/// subnormals, other radixes, and some spellings TOML rejects.
const EXTREME_NUMBERS: &[&str] = &[
    "1e308",
    "-1e308",
    "1e39",
    "3.4028235e38",
    "3.4028236e38",
    "-3.4028235e38",
    "-0",
    "-0.0",
    "+0.0",
    "0",
    "0.0",
    "nan",
    "+nan",
    "-nan",
    "inf",
    "+inf",
    "-inf",
    "1e-45",
    "1e-320",
    "-1e-40",
    "9223372036854775807",
    "-9223372036854775808",
    "9223372036854775808",
    "18446744073709551615",
    "4294967295",
    "4294967296",
    "65536",
    "65537",
    "-1",
    "-4294967296",
    "0x7fffffff",
    "0xffffffff",
    "0o777",
    "0b11",
    "1_000_000",
    "1__0",
    "01",
    ".5",
    "5.",
    "1e",
    "NaN",
    "Infinity",
    "1e1000",
];

/// Values of every other kind: empty strings, wrong types, dates, deep nesting.
pub(crate) fn odd_value() -> BoxedStrategy<String> {
    prop_oneof![
        4 => prop::sample::select(EXTREME_NUMBERS).prop_map(String::from),
        1 => Just("\"\"".to_string()),
        1 => Just("''".to_string()),
        1 => Just("\"\\u0000\"".to_string()),
        1 => Just("\"\\uD800\"".to_string()),
        1 => Just("\"\"\"\n\"\"\"".to_string()),
        1 => Just("true".to_string()),
        1 => Just("[]".to_string()),
        1 => Just("{}".to_string()),
        1 => Just("[1, \"a\", true]".to_string()),
        1 => Just("[1, 2]".to_string()),
        1 => Just("[1, 2, 3, 4]".to_string()),
        1 => Just("[nan, inf, -inf]".to_string()),
        1 => Just("[1e39, 0, 0]".to_string()),
        1 => Just("[3e38, -3e38, 3e38]".to_string()),
        1 => Just("1979-05-27T07:32:00Z".to_string()),
        1 => Just("07:32:00".to_string()),
        1 => (1usize..150).prop_map(|d| format!("{}1{}", "[".repeat(d), "]".repeat(d))),
        1 => (1usize..150).prop_map(|d| format!("{}1{}", "{a = ".repeat(d), "}".repeat(d))),
        1 => (0usize..3000).prop_map(|n| format!("\"{}\"", "x".repeat(n))),
        1 => (0usize..400).prop_map(|n| format!("[{}]", vec!["0"; n].join(","))),
    ]
    .boxed()
}

/// Formats `f` as a TOML float.
pub(crate) fn toml_float(f: f64) -> String {
    if f.is_nan() {
        "nan".into()
    } else if f.is_infinite() {
        if f > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{f:?}")
    }
}

/// A plausible number: small integers and floats, mostly in [-4, 4].
pub(crate) fn plain_number() -> BoxedStrategy<String> {
    prop_oneof![
        3 => (-4i64..=8).prop_map(|i| i.to_string()),
        3 => (-4.0f64..4.0).prop_map(toml_float),
        1 => any::<f64>().prop_map(toml_float),
        1 => any::<i64>().prop_map(|i| i.to_string()),
    ]
    .boxed()
}

/// A TOML string literal for `s`.
pub(crate) fn quote(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// A key, bare where TOML allows it.
pub(crate) fn key(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
        s.to_string()
    } else {
        quote(s)
    }
}

/// Cuts `text` to at most `max` bytes at a char boundary.
pub(crate) fn cap(mut text: String, max: usize) -> String {
    if text.len() > max {
        let mut at = max;
        while !text.is_char_boundary(at) {
            at -= 1;
        }
        text.truncate(at);
    }
    text
}

/// The tiny-render overrides most of the time, sometimes none.
pub(crate) fn standard_sets() -> BoxedStrategy<Vec<String>> {
    prop_oneof![
        6 => Just(TINY.map(String::from).to_vec()),
        1 => Just(Vec::new()),
    ]
    .boxed()
}
