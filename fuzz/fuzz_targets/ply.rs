//! Fuzz target: [`wavetrace_fuzz::ply`] (the promise it checks is documented there).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(broken) = wavetrace_fuzz::ply(data) {
        panic!("ply: {broken}");
    }
});
