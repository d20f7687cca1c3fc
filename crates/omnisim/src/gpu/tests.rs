//! The WGSL program is valid, and every host struct uploaded to the GPU has exactly the size
//! and field offsets naga computes for its WGSL twin.

use super::bindings::{self, Access};
use super::layout::host_layouts;
use super::{shader, wide};

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

/// The bindings table (`bindings.rs`) is the WGSL's: every `@group(0) @binding(n)` variable is
/// in it with its name, number and address space, and each pipeline's layout holds exactly
/// the globals its entry point uses (naga's analysis of the validated module).
#[test]
fn bindings_and_camera_kinds_are_the_wgsl_ones() {
    let module = module();
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .unwrap();
    let mut declared = Vec::new();
    for (_, global) in module.global_variables.iter() {
        let Some(binding) = &global.binding else { continue };
        let name = global.name.as_deref().unwrap_or_default();
        let access = match global.space {
            naga::AddressSpace::Uniform => Access::Uniform,
            naga::AddressSpace::Storage { access } if access.contains(naga::StorageAccess::STORE) => Access::ReadWrite,
            naga::AddressSpace::Storage { .. } => Access::Read,
            other => panic!("{name}: address space {other:?} has no table entry"),
        };
        assert_eq!(binding.group, 0, "{name}");
        declared.push(bindings::Binding {
            index: binding.binding,
            name: global.name.clone().unwrap_or_default().leak(),
            access,
        });
    }
    declared.sort_by_key(|b| b.index);
    assert_eq!(declared, bindings::ALL, "the WGSL's bindings against the table");

    for stage in bindings::STAGES {
        let (index, _) = module
            .entry_points
            .iter()
            .enumerate()
            .find(|(_, e)| e.name == stage.entry_point)
            .unwrap_or_else(|| panic!("no entry point {}", stage.entry_point));
        let uses = info.get_entry_point(index);
        let mut used: Vec<u32> = module
            .global_variables
            .iter()
            .filter(|(handle, global)| global.binding.is_some() && !uses[*handle].is_empty())
            .map(|(_, global)| global.binding.as_ref().unwrap().binding)
            .collect();
        used.sort_unstable();
        let table: Vec<u32> = stage.bindings.iter().map(|b| b.index).collect();
        assert_eq!(used, table, "bindings {} uses", stage.entry_point);
    }

    let constant = |name: &str| {
        let (_, c) = module
            .constants
            .iter()
            .find(|(_, c)| c.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no WGSL constant {name}"));
        match module.global_expressions[c.init] {
            naga::Expression::Literal(naga::Literal::U32(value)) => value,
            ref other => panic!("{name} = {other:?}"),
        }
    };
    for (name, kind) in bindings::CAMERA_KINDS {
        assert_eq!(constant(name), kind, "{name}");
    }
    assert_eq!(constant("STACK_SIZE") as usize, shader::STACK_SIZE);
    assert_eq!(constant("LEAF"), wide::GPU_LEAF);
    assert_eq!(constant("LEAF_COUNT_SHIFT"), wide::GPU_LEAF_COUNT_SHIFT);
    assert_eq!(constant("LEAF_FIRST") as usize, wide::GPU_MAX_TRIANGLES - 1);
}
