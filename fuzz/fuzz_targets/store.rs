//! A store file: opening checks its header, index and values; a store that opens answers every
//! node's verification and the root's queries without panicking.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    // Stores are read from 8-byte aligned memory maps.
    let mut words = vec![0u64; data.len().div_ceil(8)];
    let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut words);
    bytes[..data.len()].copy_from_slice(data);
    let Ok(store) = kiosk_core::Store::open(&bytes[..data.len()]) else { return };
    for id in 0..store.nodes().len() as u32 {
        let _ = store.verify_node(id);
    }
    let _ = store.bbox();
});
