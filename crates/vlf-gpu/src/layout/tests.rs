use super::*;
use crate::shaders::ALL;
use wgpu::naga;

/// A WGSL struct member as naga lays it out.
struct Member {
    name: String,
    offset: usize,
    size: usize,
}

/// Layout of struct `name` in `file` (resolved and validated): members, size, alignment.
fn wgsl_layout(name: &str, file: &str) -> Result<(Vec<Member>, usize, usize), String> {
    let shader = ALL
        .iter()
        .find(|s| s.file == file)
        .ok_or_else(|| format!("{file} is not registered in shaders::ALL"))?;
    if !shader.source.contains(&format!("struct {name} {{")) {
        return Err(format!("{file} does not define struct {name} itself"));
    }
    let module = shader.validate().map_err(|e| e.to_string())?;
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(module.to_ctx())
        .map_err(|e| e.to_string())?;
    let (handle, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .ok_or_else(|| format!("struct {name} not found in {file}"))?;
    let naga::TypeInner::Struct { members, span } = &ty.inner else {
        return Err(format!("{name} in {file} is not a struct"));
    };
    let members = members
        .iter()
        .map(|m| Member {
            name: m.name.clone().unwrap_or_default(),
            offset: m.offset as usize,
            size: layouter[m.ty].size as usize,
        })
        .collect();
    let align = layouter[handle].alignment.round_up(1) as usize;
    Ok((members, *span as usize, align))
}

/// What differs between a Rust struct and its WGSL mirror (empty when they agree).
fn compare(s: &SharedStruct) -> Vec<String> {
    let (members, span, wgsl_align) = match wgsl_layout(s.name, s.file) {
        Ok(layout) => layout,
        Err(e) => return vec![e],
    };
    let mut problems = Vec::new();
    // Pod structs have no padding: the listed fields must tile the struct, or one is missing.
    let mut by_offset = s.fields.clone();
    by_offset.sort_by_key(|f| f.offset);
    let mut end = 0;
    for f in &by_offset {
        if f.offset != end {
            problems.push(format!(
                "Rust bytes {end}..{} are not in layout::registry()'s field list",
                f.offset
            ));
        }
        end = f.offset + f.size;
    }
    if end != s.size {
        problems.push(format!(
            "Rust bytes {end}..{} are not in layout::registry()'s field list",
            s.size
        ));
    }
    let rust_names: Vec<&str> = s.fields.iter().map(|f| f.name).collect();
    let wgsl_names: Vec<&str> = members.iter().map(|m| m.name.as_str()).collect();
    if let Some(i) = (0..rust_names.len().max(wgsl_names.len()))
        .find(|&i| rust_names.get(i) != wgsl_names.get(i))
    {
        problems.push(format!(
            "member #{i} is {} in WGSL but {} in Rust",
            wgsl_names
                .get(i)
                .map_or("absent".into(), |n| format!("`{n}`")),
            rust_names
                .get(i)
                .map_or("absent".into(), |n| format!("`{n}`")),
        ));
    }
    for f in &s.fields {
        match members.iter().find(|m| m.name == f.name) {
            None => problems.push(format!("field `{}` is missing in WGSL", f.name)),
            Some(m) if (m.offset, m.size) != (f.offset, f.size) => problems.push(format!(
                "field `{}`: WGSL offset {} size {}, Rust offset {} size {}",
                f.name, m.offset, m.size, f.offset, f.size
            )),
            Some(_) => {}
        }
    }
    for m in &members {
        if !rust_names.contains(&m.name.as_str()) {
            problems.push(format!("member `{}` is missing in Rust", m.name));
        }
    }
    if span != s.size {
        problems.push(format!("size: WGSL {span}, Rust {}", s.size));
    }
    // Arrays of the struct need the same stride on both sides, and Rust may not need more
    // alignment than WGSL gives.
    if !s.size.is_multiple_of(wgsl_align) || s.align > wgsl_align {
        problems.push(format!(
            "alignment: WGSL {wgsl_align}, Rust {}, size {}",
            s.align, s.size
        ));
    }
    problems
        .into_iter()
        .map(|p| format!("{} ({}): {p}", s.name, s.file))
        .collect()
}

#[test]
fn rust_structs_match_wgsl() {
    let reg = registry();
    assert!(reg.len() >= 19, "{} structs registered", reg.len());
    let mut names: Vec<_> = reg.iter().map(|s| s.name).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), reg.len(), "a struct is registered twice");
    let problems: Vec<String> = reg.iter().flat_map(compare).collect();
    assert!(
        problems.is_empty(),
        "Rust and WGSL layouts differ:\n{}",
        problems.join("\n")
    );
}

/// The comparison catches what a size-only check cannot: two same-sized fields swapped.
#[test]
fn swapped_fields_are_caught() {
    let mut s = registry()
        .into_iter()
        .find(|s| s.name == "BakeDirection")
        .unwrap();
    assert!(compare(&s).is_empty());
    let tile = s.fields.iter().position(|f| f.name == "tile").unwrap();
    let k_max = s.fields.iter().position(|f| f.name == "k_max").unwrap();
    s.fields[tile].name = "k_max";
    s.fields[k_max].name = "tile";
    let problems = compare(&s);
    assert!(
        problems
            .iter()
            .any(|p| p.contains("member #6 is `tile` in WGSL but `k_max` in Rust"))
            && problems
                .iter()
                .any(|p| p.contains("field `tile`: WGSL offset 72 size 4, Rust offset 76")),
        "{problems:#?}"
    );
}
