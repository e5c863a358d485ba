//! Fuzz target: [`wavetrace_fuzz::scene_values`], structure-aware scenes drawn by
//! `arbitrary` and written as TOML or Mitsuba XML.
#![no_main]

libfuzzer_sys::fuzz_target!(|values: wavetrace_fuzz::SceneValues| {
    if let Err(broken) = wavetrace_fuzz::scene_values(&values) {
        panic!(
            "scene_values: {broken}\n--- as written ---\n{}",
            if values.xml { values.to_xml() } else { values.to_toml() }
        );
    }
});
