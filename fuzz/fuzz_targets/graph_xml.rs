//! graph.xml: a graph with its problems or an error; what is read writes back and reads again
//! to the same graph, and saving over the original never fails on a file that loaded.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok((graph, _)) = kiosk_core::graph::InfoGraph::from_xml(text) else { return };
    let xml = graph.to_xml();
    let (again, _) = kiosk_core::graph::InfoGraph::from_xml(&xml).expect("own output reads back");
    assert_eq!(again.nodes.len(), graph.nodes.len());
    assert_eq!(again.edges.len(), graph.edges.len());
    let over = graph.to_xml_over(text).expect("a file that loaded can be saved over");
    let (merged, _) = kiosk_core::graph::InfoGraph::from_xml(&over).expect("saved file reads back");
    assert_eq!(merged.nodes.len(), graph.nodes.len());
});
