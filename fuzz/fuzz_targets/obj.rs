#![no_main]
//! The OBJ loader on arbitrary bytes, then the structures built over what it loads.
libfuzzer_sys::fuzz_target!(|data: &[u8]| hugrt::fuzzing::scene_file("fuzz.obj", data));
