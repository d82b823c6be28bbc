//! `KHR_materials_variants`: a file names material variants and each primitive maps some of them
//! to other materials. Without a chosen variant every primitive keeps its own `material` (the
//! default, as Blender's importer shows the file); `LoadOptions::variant` picks one by name.

use super::container::Loader;
use crate::error::Result;
use serde_json::Value;

const EXTENSION: &str = "KHR_materials_variants";

impl Loader {
    /// The index of the variant named `name` in the file's list, or an error listing them.
    pub(super) fn choose_variant(&mut self, name: &str) -> Result<()> {
        let names: Vec<String> = self
            .document
            .extension_value(EXTENSION)
            .and_then(|e| e.get("variants"))
            .and_then(Value::as_array)
            .map(|list| {
                list.iter()
                    .map(|v| {
                        v.get("name")
                            .and_then(Value::as_str)
                            .unwrap_or("")
                            .to_string()
                    })
                    .collect()
            })
            .unwrap_or_default();
        match names.iter().position(|n| n == name) {
            Some(index) => {
                self.variant = Some(index);
                Ok(())
            }
            None => {
                let available = if names.is_empty() {
                    "the file has no KHR_materials_variants variants".to_string()
                } else {
                    let quoted: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
                    format!("available: {}", quoted.join(", "))
                };
                Err(self.err(
                    format!("variant '{name}'"),
                    format!("no such material variant; {available}"),
                ))
            }
        }
    }

    /// The glTF material `primitive` shows in the chosen variant: the material its
    /// `KHR_materials_variants` mapping gives that variant, else its own.
    pub(super) fn variant_material(&self, primitive: &gltf::Primitive) -> Result<Option<usize>> {
        let own = primitive.material().index();
        let Some(variant) = self.variant else {
            return Ok(own);
        };
        let Some(mappings) = primitive
            .extension_value(EXTENSION)
            .and_then(|e| e.get("mappings"))
            .and_then(Value::as_array)
        else {
            return Ok(own);
        };
        for mapping in mappings {
            let lists = mapping
                .get("variants")
                .and_then(Value::as_array)
                .is_some_and(|v| v.iter().any(|i| i.as_u64() == Some(variant as u64)));
            if !lists {
                continue;
            }
            let material = mapping.get("material").and_then(Value::as_u64);
            let count = self.document.materials().len();
            return match material {
                Some(m) if (m as usize) < count => Ok(Some(m as usize)),
                _ => Err(self.err(
                    format!("primitive {} {EXTENSION}", primitive.index()),
                    format!(
                        "'material' must name one of the file's {count} materials, found {mapping}"
                    ),
                )),
            };
        }
        Ok(own)
    }
}
