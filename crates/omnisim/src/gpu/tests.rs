//! The WGSL program is valid, and every host struct uploaded to the GPU has exactly the size
//! and field offsets naga computes for its WGSL twin.

use super::layout::host_layouts;
use super::shader;

fn module() -> naga::Module {
    naga::front::wgsl::parse_str(&shader::source())
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&shader::source())))
}

#[test]
fn every_shader_file_is_valid_wgsl() {
    let module = module();
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&shader::source())));
    let trace = module
        .entry_points
        .iter()
        .find(|e| e.name == shader::ENTRY_POINT)
        .expect("trace entry point");
    assert_eq!(
        trace.workgroup_size,
        [shader::WORKGROUP_SIZE[0], shader::WORKGROUP_SIZE[1], 1]
    );
    let refine = module
        .entry_points
        .iter()
        .find(|e| e.name == shader::REFINE_ENTRY_POINT)
        .expect("refine entry point");
    assert_eq!(refine.workgroup_size, [shader::REFINE_WORKGROUP_SIZE, 1, 1]);
    assert_eq!(
        shader::FILES.len(),
        std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shaders"))
            .unwrap()
            .count()
    );
}

#[test]
fn host_structs_match_wgsl_layout() {
    let module = module();
    for (name, size, fields) in host_layouts() {
        let ty = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no WGSL struct {name}"))
            .1;
        let naga::TypeInner::Struct { members, span } = &ty.inner else {
            panic!("{name} is not a struct in WGSL")
        };
        assert_eq!(*span as usize, size, "size of {name}");
        for &(field, offset) in &fields {
            let member = members
                .iter()
                .find(|m| m.name.as_deref() == Some(field))
                .unwrap_or_else(|| panic!("WGSL {name} has no field {field}"));
            assert_eq!(member.offset as usize, offset, "offset of {name}.{field}");
        }
        // Every WGSL field but padding has a host twin checked above.
        for member in members.iter().filter_map(|m| m.name.as_deref()) {
            assert!(
                member.starts_with('_') || fields.iter().any(|(field, _)| *field == member),
                "{name}.{member} has no checked host twin"
            );
        }
    }
}
