//! Fuzz target: [`wavetrace_fuzz::mitsuba_xml`] (the promise it checks is documented there).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(broken) = wavetrace_fuzz::mitsuba_xml(data) {
        panic!("mitsuba_xml: {broken}");
    }
});
