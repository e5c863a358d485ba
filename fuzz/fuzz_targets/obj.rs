//! Fuzz target: [`wavetrace_fuzz::obj`] (the promise it checks is documented there).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(broken) = wavetrace_fuzz::obj(data) {
        panic!("obj: {broken}");
    }
});
