//! Fuzz target: [`wavetrace_fuzz::image`] (the promise it checks is documented there).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(broken) = wavetrace_fuzz::image(data) {
        panic!("image: {broken}");
    }
});
