#![no_main]
//! The STL loader (ASCII and binary) on arbitrary bytes, then the structures built over what it loads.
libfuzzer_sys::fuzz_target!(|data: &[u8]| hugrt::fuzzing::scene_file("fuzz.stl", data));
