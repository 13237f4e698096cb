//! Byte-identical EXR files for identical frames. The exr crate keeps custom attributes in a
//! `HashMap` and writes them in its iteration order, which is seeded randomly per map, so two
//! writes of the same frame would list the `wedge.*` attributes in different orders. After
//! encoding we therefore sort the header's attributes by name, which is also the order the
//! OpenEXR reference library writes (its `Header` keeps attributes in a `std::map`). Sorting
//! moves bytes within the header without changing its length, so the chunk offset table that
//! follows, which holds absolute file positions, stays valid.

const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
/// Version-field flag of multi-part files, whose several headers we do not handle.
const MULTIPART_FLAG: u32 = 1 << 12;

/// Sorts the attributes of a single-part EXR header in place, by name.
pub(super) fn sort_header_attributes(file: &mut [u8]) -> Result<(), String> {
    let attributes = header_attributes(file)?;
    let (start, end) = match (attributes.first(), attributes.last()) {
        (Some(first), Some(last)) => (first.start, last.end),
        _ => return Ok(()),
    };
    let mut sorted = attributes.clone();
    sorted.sort_by(|a, b| a.name(file).cmp(b.name(file)));
    let bytes: Vec<u8> = sorted.iter().flat_map(|a| &file[a.start..a.end]).copied().collect();
    file[start..end].copy_from_slice(&bytes);
    Ok(())
}

/// Where one attribute (name, type name, size, value) lies in the file.
#[derive(Clone, Copy)]
pub(super) struct AttributeSpan {
    start: usize,
    name_end: usize,
    end: usize,
}

impl AttributeSpan {
    pub(super) fn name<'f>(&self, file: &'f [u8]) -> &'f [u8] {
        &file[self.start..self.name_end]
    }
}

/// The attributes of the (single) header, in file order.
pub(super) fn header_attributes(file: &[u8]) -> Result<Vec<AttributeSpan>, String> {
    let truncated = || "truncated header".to_string();
    if file.get(..4) != Some(&MAGIC[..]) {
        return Err("not an OpenEXR file".into());
    }
    let version = u32::from_le_bytes(file.get(4..8).ok_or_else(truncated)?.try_into().unwrap());
    if version & MULTIPART_FLAG != 0 {
        return Err("multi-part file".into());
    }
    let null_terminated_end = |from: usize| {
        file.get(from..).and_then(|rest| rest.iter().position(|&b| b == 0)).map(|n| from + n).ok_or_else(truncated)
    };
    let mut spans = Vec::new();
    let mut position = 8;
    // The header ends with an empty attribute name, i.e. a lone null byte.
    while *file.get(position).ok_or_else(truncated)? != 0 {
        let name_end = null_terminated_end(position)?;
        let type_end = null_terminated_end(name_end + 1)?;
        let size_at = type_end + 1;
        let size = file.get(size_at..size_at + 4).ok_or_else(truncated)?;
        let size = i32::from_le_bytes(size.try_into().unwrap());
        let size = usize::try_from(size).map_err(|_| "negative attribute size".to_string())?;
        let end = size_at + 4 + size;
        if end > file.len() {
            return Err(truncated());
        }
        spans.push(AttributeSpan { start: position, name_end, end });
        position = end;
    }
    Ok(spans)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attribute(name: &str, kind: &str, value: &[u8]) -> Vec<u8> {
        let mut bytes = Vec::new();
        bytes.extend_from_slice(name.as_bytes());
        bytes.push(0);
        bytes.extend_from_slice(kind.as_bytes());
        bytes.push(0);
        bytes.extend_from_slice(&(value.len() as i32).to_le_bytes());
        bytes.extend_from_slice(value);
        bytes
    }

    fn file(attributes: &[Vec<u8>], rest: &[u8]) -> Vec<u8> {
        let mut bytes = MAGIC.to_vec();
        bytes.extend_from_slice(&2u32.to_le_bytes());
        attributes.iter().for_each(|a| bytes.extend_from_slice(a));
        bytes.push(0);
        bytes.extend_from_slice(rest);
        bytes
    }

    #[test]
    fn sorts_attributes_and_keeps_the_rest() {
        let b = attribute("b", "int", &7i32.to_le_bytes());
        let a = attribute("a", "string", b"xyz");
        let c = attribute("c", "float", &1f32.to_le_bytes());
        let mut unsorted = file(&[c.clone(), a.clone(), b.clone()], b"chunks");
        sort_header_attributes(&mut unsorted).unwrap();
        assert_eq!(unsorted, file(&[a, b, c], b"chunks"));
    }

    #[test]
    fn rejects_what_it_cannot_parse() {
        assert!(sort_header_attributes(&mut b"not exr".to_vec()).is_err());
        let mut truncated = file(&[attribute("a", "string", b"xyz")], b"");
        truncated.truncate(truncated.len() - 3);
        assert!(sort_header_attributes(&mut truncated).is_err());
        let mut multipart = file(&[], b"");
        multipart[5] |= 0x10;
        assert!(sort_header_attributes(&mut multipart).is_err());
    }
}
