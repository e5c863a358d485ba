//! Fuzz target: [`wavetrace_fuzz::scene_toml`] (the promise it checks is documented there).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(broken) = wavetrace_fuzz::scene_toml(data) {
        panic!("scene_toml: {broken}");
    }
});
