//! glTF accessors read with every byte range checked before anything is allocated: strides,
//! sparse substitution, normalized and quantized integer components (KHR_mesh_quantization),
//! and the component types glTF allows for each vertex attribute.

use super::container::{named, Loader};
use crate::error::Result;
use crate::math::Vec3;
use gltf::accessor::DataType;

/// An accessor without a buffer view is all zeros; refuse absurd counts for those.
pub(super) const MAX_VIEWLESS_ELEMENTS: usize = 1 << 24;

impl Loader {
    /// The checks `read_accessor` makes before allocating, without reading: the elements fit
    /// in the buffer view, or a view-less accessor is not absurdly long.
    pub(super) fn check_accessor_fits(&self, accessor: &gltf::Accessor) -> Result<()> {
        let object = named("accessor", accessor.index(), accessor.name());
        let element_size = accessor.dimensions().multiplicity() * accessor.data_type().size();
        match accessor.view() {
            Some(view) => {
                self.element_region(
                    &view,
                    accessor.offset(),
                    accessor.count(),
                    element_size,
                    &object,
                )?;
            }
            None if accessor.count() > MAX_VIEWLESS_ELEMENTS
                && !self.decoded_accessors.contains_key(&accessor.index()) =>
            {
                return Err(self.err(
                    &object,
                    format!(
                        "count {} without a buffer view is too large",
                        accessor.count()
                    ),
                ));
            }
            None => {}
        }
        Ok(())
    }

    pub(super) fn read_vec3(
        &self,
        accessor: &gltf::Accessor,
        object: &str,
        what: &str,
    ) -> Result<Vec<Vec3>> {
        let flat = self.read_float_attribute(accessor, object, what, 3)?;
        Ok(flat
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect())
    }

    /// An attribute as floats, `components` per element (checked against the accessor type).
    pub(super) fn read_float_attribute(
        &self,
        accessor: &gltf::Accessor,
        object: &str,
        what: &str,
        components: usize,
    ) -> Result<Vec<f32>> {
        let found = accessor.dimensions().multiplicity();
        if found != components {
            return Err(self.err(
                format!("{object} {what} (accessor {})", accessor.index()),
                format!("has {found} components per element, expected {components}"),
            ));
        }
        check_attribute_type(
            what,
            accessor.data_type(),
            accessor.normalized(),
            self.quantized,
        )
        .map_err(|m| {
            self.err(
                format!("{object} {what} (accessor {})", accessor.index()),
                m,
            )
        })?;
        self.read_accessor(accessor, component_as_f32)
    }

    pub(super) fn read_indices(&self, accessor: &gltf::Accessor, object: &str) -> Result<Vec<u32>> {
        let integer = matches!(
            accessor.data_type(),
            DataType::U8 | DataType::U16 | DataType::U32
        );
        if accessor.dimensions().multiplicity() != 1 || !integer {
            return Err(self.err(
                format!("{object} indices (accessor {})", accessor.index()),
                "indices must be scalar unsigned integers",
            ));
        }
        self.read_accessor(accessor, component_as_u32)
    }

    /// Every component of every element, decoded by `decode`, with all byte ranges checked
    /// before anything is allocated. Handles strides and sparse substitution.
    pub(super) fn read_accessor<T: Copy + Default>(
        &self,
        accessor: &gltf::Accessor,
        decode: fn(&[u8], DataType, bool) -> T,
    ) -> Result<Vec<T>> {
        let object = named("accessor", accessor.index(), accessor.name());
        let e = Elements::of(accessor);
        let Elements {
            count,
            components,
            data_type,
            component_size,
            element_size,
            normalized,
        } = e;
        let total = count
            .checked_mul(components)
            .ok_or_else(|| self.err(&object, format!("count {count} is absurd")))?;

        // The elements' bytes and stride: the view's, or the bytes a compressed primitive
        // decoded to (`draco`); `None` for no elements.
        let region = match accessor.view() {
            Some(view) => {
                self.element_region(&view, accessor.offset(), count, element_size, &object)?
            }
            None => match self.decoded_accessors.get(&accessor.index()) {
                Some(bytes) if bytes.len() == count.saturating_mul(element_size) => {
                    (count > 0).then_some((&bytes[..], element_size))
                }
                Some(bytes) => {
                    return Err(self.err(
                        &object,
                        format!("decoded to {} bytes, not {count} elements", bytes.len()),
                    ))
                }
                None if count > MAX_VIEWLESS_ELEMENTS => {
                    return Err(self.err(
                        &object,
                        format!("count {count} without a buffer view is too large"),
                    ))
                }
                None => {
                    return self.sparse_over(
                        accessor,
                        e,
                        vec![T::default(); total],
                        decode,
                        &object,
                    )
                }
            },
        };
        let mut values = Vec::with_capacity(total);
        if let Some((bytes, stride)) = region {
            for element in bytes.chunks(stride).take(count) {
                for c in 0..components {
                    let start = c * component_size;
                    values.push(decode(
                        &element[start..start + component_size],
                        data_type,
                        normalized,
                    ));
                }
            }
        }
        self.sparse_over(accessor, e, values, decode, &object)
    }

    /// `values` with the accessor's sparse substitution applied.
    fn sparse_over<T: Copy + Default>(
        &self,
        accessor: &gltf::Accessor,
        e: Elements,
        mut values: Vec<T>,
        decode: fn(&[u8], DataType, bool) -> T,
        object: &str,
    ) -> Result<Vec<T>> {
        let (count, components, data_type) = (e.count, e.components, e.data_type);
        let (component_size, element_size) = (e.component_size, e.element_size);
        let normalized = e.normalized;
        if let Some(sparse) = accessor.sparse() {
            let sparse_count = sparse.count();
            let indices = sparse.indices();
            let index_type = match indices.index_type() {
                gltf::accessor::sparse::IndexType::U8 => DataType::U8,
                gltf::accessor::sparse::IndexType::U16 => DataType::U16,
                gltf::accessor::sparse::IndexType::U32 => DataType::U32,
            };
            let index_region = self.element_region(
                &indices.view(),
                indices.offset(),
                sparse_count,
                index_type.size(),
                &format!("{object} sparse indices"),
            )?;
            let values_view = sparse.values().view();
            let value_region = self.element_region(
                &values_view,
                sparse.values().offset(),
                sparse_count,
                element_size,
                &format!("{object} sparse values"),
            )?;
            if let (Some((index_bytes, index_stride)), Some((value_bytes, value_stride))) =
                (index_region, value_region)
            {
                let targets = index_bytes.chunks(index_stride).take(sparse_count);
                let sources = value_bytes.chunks(value_stride).take(sparse_count);
                for (index_chunk, element) in targets.zip(sources) {
                    let target =
                        component_as_u32(&index_chunk[..index_type.size()], index_type, false)
                            as usize;
                    if target >= count {
                        return Err(self.err(
                            object,
                            format!("sparse index {target} is past the count {count}"),
                        ));
                    }
                    for c in 0..components {
                        let start = c * component_size;
                        values[target * components + c] = decode(
                            &element[start..start + component_size],
                            data_type,
                            normalized,
                        );
                    }
                }
            }
        }
        Ok(values)
    }

    /// The bytes `count` elements of `element_size` occupy in `view` from `offset`, with the
    /// stride; `None` when `count` is zero. Errors when any of it lies outside the view or buffer.
    pub(super) fn element_region(
        &self,
        view: &gltf::buffer::View,
        offset: usize,
        count: usize,
        element_size: usize,
        object: &str,
    ) -> Result<Option<(&[u8], usize)>> {
        let view_bytes = self.view_bytes(view)?;
        if count == 0 {
            return Ok(None);
        }
        let stride = view.stride().unwrap_or(element_size);
        if stride < element_size {
            return Err(self.err(
                object,
                format!("byte stride {stride} is smaller than the element size {element_size}"),
            ));
        }
        let needed = stride
            .checked_mul(count - 1)
            .and_then(|n| n.checked_add(element_size))
            .and_then(|n| n.checked_add(offset));
        match needed.and_then(|end| view_bytes.get(offset..end)) {
            Some(bytes) => Ok(Some((bytes, stride))),
            None => Err(self.err(
                object,
                format!(
                    "{count} elements of {element_size} bytes (stride {stride}) from offset \
                     {offset} do not fit in buffer view {} of {} bytes",
                    view.index(),
                    view_bytes.len()
                ),
            )),
        }
    }

    /// A buffer view's bytes: its range of its buffer, or its decoded bytes when it is stored
    /// compressed (`meshopt`).
    fn view_bytes(&self, view: &gltf::buffer::View) -> Result<&[u8]> {
        if let Some(decoded) = self.decoded_views.get(&view.index()) {
            return Ok(decoded);
        }
        let view_object = format!("buffer view {}", view.index());
        let buffer = self.buffers.get(view.buffer().index()).ok_or_else(|| {
            self.err(
                &view_object,
                format!("buffer {} is not loaded", view.buffer().index()),
            )
        })?;
        let view_end = view.offset().checked_add(view.length());
        view_end
            .and_then(|end| buffer.get(view.offset()..end))
            .ok_or_else(|| {
                self.err(
                    &view_object,
                    format!(
                        "bytes {}..{} lie outside buffer {} ({} bytes)",
                        view.offset(),
                        view.offset().saturating_add(view.length()),
                        view.buffer().index(),
                        buffer.len()
                    ),
                )
            })
    }
}

/// How an accessor's elements are laid out.
#[derive(Clone, Copy)]
struct Elements {
    count: usize,
    components: usize,
    data_type: DataType,
    component_size: usize,
    element_size: usize,
    normalized: bool,
}

impl Elements {
    fn of(accessor: &gltf::Accessor) -> Elements {
        let components = accessor.dimensions().multiplicity();
        let data_type = accessor.data_type();
        Elements {
            count: accessor.count(),
            components,
            data_type,
            component_size: data_type.size(),
            element_size: components * data_type.size(),
            normalized: accessor.normalized(),
        }
    }
}

/// One accessor component as f32, applying glTF's normalisation of integer types.
pub(super) fn component_as_f32(bytes: &[u8], data_type: DataType, normalized: bool) -> f32 {
    let raw = |scale: f32, value: f32| {
        if normalized {
            (value / scale).max(-1.0)
        } else {
            value
        }
    };
    match (data_type, bytes) {
        (DataType::F32, &[a, b, c, d]) => f32::from_le_bytes([a, b, c, d]),
        (DataType::U8, &[a]) => raw(255.0, a as f32),
        (DataType::I8, &[a]) => raw(127.0, a as i8 as f32),
        (DataType::U16, &[a, b]) => raw(65535.0, u16::from_le_bytes([a, b]) as f32),
        (DataType::I16, &[a, b]) => raw(32767.0, i16::from_le_bytes([a, b]) as f32),
        (DataType::U32, &[a, b, c, d]) => {
            raw(u32::MAX as f32, u32::from_le_bytes([a, b, c, d]) as f32)
        }
        _ => f32::NAN,
    }
}

/// Whether glTF lets vertex attribute `what` be stored with this component type: floats always;
/// normalized unsigned bytes and shorts for texture coordinates; and with KHR_mesh_quantization
/// (`quantized`) the integer types that extension lists (POSITION and TEXCOORD normalized or not,
/// NORMAL and TANGENT normalized signed). Integers read as they are (normalized ones mapped to
/// [0, 1] or [−1, 1]); the node transform then dequantizes them, as the extension intends.
pub(super) fn check_attribute_type(
    what: &str,
    data_type: DataType,
    normalized: bool,
    quantized: bool,
) -> std::result::Result<(), String> {
    use DataType::{F32, I16, I8, U16, U8};
    // Every texture coordinate and colour set as the first.
    let what = match what {
        w if w.starts_with("TEXCOORD_") => "TEXCOORD",
        w if w.starts_with("COLOR_") => "COLOR",
        w => w,
    };
    let allowed = match (what, data_type) {
        (_, F32) => !normalized,
        ("TEXCOORD" | "COLOR", U8 | U16) if normalized => true,
        ("POSITION" | "TEXCOORD", I8 | U8 | I16 | U16) => quantized,
        ("NORMAL" | "TANGENT", I8 | I16) => quantized && normalized,
        _ => false,
    };
    if allowed {
        return Ok(());
    }
    let kind = match data_type {
        I8 => "signed bytes",
        U8 => "unsigned bytes",
        I16 => "signed shorts",
        U16 => "unsigned shorts",
        DataType::U32 => "unsigned 32-bit integers",
        F32 => "floats",
    };
    let norm = if normalized { "normalized " } else { "" };
    let quantizable = !matches!(data_type, F32 | DataType::U32);
    Err(if quantizable && !quantized {
        format!(
            "is stored as {norm}{kind}, which glTF allows only with the KHR_mesh_quantization \
             extension, and the file does not declare it (a broken exporter? read as numbers \
             it would give garbage geometry)"
        )
    } else {
        format!("cannot be stored as {norm}{kind} (glTF and KHR_mesh_quantization forbid it)")
    })
}

/// One unsigned integer accessor component.
pub(super) fn component_as_u32(bytes: &[u8], data_type: DataType, _normalized: bool) -> u32 {
    match (data_type, bytes) {
        (DataType::U8, &[a]) => a as u32,
        (DataType::U16, &[a, b]) => u16::from_le_bytes([a, b]) as u32,
        (DataType::U32, &[a, b, c, d]) => u32::from_le_bytes([a, b, c, d]),
        _ => u32::MAX,
    }
}
