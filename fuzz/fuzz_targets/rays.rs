#![no_main]
//! The rays-file reader on arbitrary bytes, its rays traced through the checked structures.
libfuzzer_sys::fuzz_target!(|data: &[u8]| hugrt::fuzzing::rays_file(data));
