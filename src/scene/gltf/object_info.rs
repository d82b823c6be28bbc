//! `PHOTON_object`'s "info": what Blender's Object Info node reads of an object or instance
//! (its location, colour, pass index and random id) and the values of the Object and Instancer
//! attributes node trees read (as Cycles' `sync_object_attributes` finds them), into
//! `shader::ObjectInfo`.

use crate::math::{Vec3, Vec4};
use crate::shader::{ObjectInfo, OBJECT_ATTRIBUTES};
use serde_json::Value;

/// The object info in `value` (`{"location": [x, y, z], "color": [r, g, b, a], "pass_index":
/// n, "random_id": u32, "attributes": [[r, g, b, a], …]}`, each field optional); an error
/// names the field.
pub(super) fn read(value: &Value) -> Result<ObjectInfo, String> {
    let fail = |key: &str, v: &Value| format!("'info' '{key}' is out of range: {v}");
    let Some(object) = value.as_object() else {
        return Err(format!("'info' must be a JSON object, found {value}"));
    };
    let numbers = |key: &str, n: usize| -> Result<Option<Vec<f32>>, String> {
        let Some(v) = object.get(key) else {
            return Ok(None);
        };
        let list: Option<Vec<f32>> = v
            .as_array()
            .filter(|a| a.len() == n)
            .and_then(|a| a.iter().map(|x| x.as_f64().map(|x| x as f32)).collect());
        match list {
            Some(list) if list.iter().all(|x| x.is_finite()) => Ok(Some(list)),
            _ => Err(fail(key, v)),
        }
    };
    let mut info = ObjectInfo::default();
    if let Some(l) = numbers("location", 3)? {
        info.location = Vec3::new(l[0], l[1], l[2]);
    }
    if let Some(c) = numbers("color", 4)? {
        info.color = Vec4::new(c[0], c[1], c[2], c[3]);
    }
    if let Some(v) = object.get("pass_index") {
        info.pass_index = v
            .as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| fail("pass_index", v))? as f32;
    }
    if let Some(v) = object.get("random_id") {
        let id = v
            .as_u64()
            .and_then(|x| u32::try_from(x).ok())
            .ok_or_else(|| fail("random_id", v))?;
        info.random = ObjectInfo::random_of(id);
    }
    if let Some(v) = object.get("attributes") {
        let list = v
            .as_array()
            .filter(|a| a.len() <= OBJECT_ATTRIBUTES)
            .ok_or_else(|| {
                format!("'info' 'attributes' must be a list of at most {OBJECT_ATTRIBUTES} RGBA values, found {v}")
            })?;
        for (slot, value) in list.iter().enumerate() {
            let rgba: Option<Vec<f32>> = value
                .as_array()
                .filter(|a| a.len() == 4)
                .and_then(|a| a.iter().map(|x| x.as_f64().map(|x| x as f32)).collect());
            match rgba {
                Some(c) if c.iter().all(|x| x.is_finite()) => {
                    info.attributes[slot] = Vec4::new(c[0], c[1], c[2], c[3])
                }
                _ => return Err(fail("attributes", value)),
            }
        }
    }
    Ok(info)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn object_info_reads_each_field_and_names_a_bad_one() {
        let value = serde_json::json!({
            "location": [1.0, 2.0, 3.0], "color": [0.5, 0.25, 1.0, 0.75],
            "pass_index": 7, "random_id": 4294967295u32,
            "attributes": [[0.0, 0.0, 0.0, 0.0], [0.5, 1.0, 2.0, 1.0]],
        });
        let info = read(&value).unwrap();
        assert_eq!(info.location, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(info.color, Vec4::new(0.5, 0.25, 1.0, 0.75));
        assert_eq!(info.pass_index, 7.0);
        assert_eq!(info.random, 1.0);
        assert_eq!(info.attributes[1], Vec4::new(0.5, 1.0, 2.0, 1.0));
        assert_eq!(info.attributes[2], Vec4::ZERO);
        assert_eq!(read(&serde_json::json!({})).unwrap(), ObjectInfo::default());
        let bad = read(&serde_json::json!({"random_id": -1})).unwrap_err();
        assert!(bad.contains("random_id"), "{bad}");
        for bad in [
            serde_json::json!({"attributes": [[1.0, 2.0, 3.0]]}),
            serde_json::json!({"attributes": vec![[0.0f32; 4]; 9]}),
        ] {
            let message = read(&bad).unwrap_err();
            assert!(message.contains("attributes"), "{message}");
        }
    }
}
