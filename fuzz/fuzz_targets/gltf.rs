#![no_main]
//! The glTF loader (JSON and GLB) on arbitrary bytes, then the structures built over what it loads.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let name = if data.starts_with(b"glTF") { "fuzz.glb" } else { "fuzz.gltf" };
    hugrt::fuzzing::scene_file(name, data)
});
