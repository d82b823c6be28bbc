//! A Draco mesh from its bytes (Draco bitstream specification 2.2, "Draco decoder"): the
//! header (version 2.2, triangular mesh, sequential or Edgebreaker connectivity), the
//! metadata skipped, the connectivity, then each group of attributes in its traversal order.
//! The caller's expected face and point counts bound every allocation; point clouds and older
//! bitstream versions are refused by name.

use super::attributes::{decode_group, read_layouts, Attribute, Positions};
use super::buffer::{Decoded, Reader};
use super::corner_table::{CornerTable, NONE};
use super::seams::{assign_points, attribute_table, AttributeTable};
use super::traversal::sequence;
use super::{edgebreaker, sequential};

/// An Edgebreaker mesh's tables and the point of each corner.
struct Tables {
    mesh: CornerTable,
    attributes: Vec<AttributeTable>,
    corner_to_point: Vec<u32>,
}

/// A decoded Draco mesh: triangles of point indices and the attributes of the points.
pub(super) struct DracoMesh {
    pub(super) faces: Vec<[u32; 3]>,
    pub(super) points: usize,
    pub(super) attributes: Vec<Attribute>,
}

/// Decode `data`, which the glTF file says holds `faces` triangles over `points` points.
pub(super) fn decode(data: &[u8], faces: usize, points: usize) -> Decoded<DracoMesh> {
    let mut r = Reader::new(data);
    if r.bytes(5, "the header").ok() != Some(b"DRACO".as_slice()) {
        return Err(
            "the data does not start with Draco's 'DRACO' header: the file is damaged".into(),
        );
    }
    let (major, minor) = (r.u8("the header")?, r.u8("the header")?);
    if (major, minor) != (2, 2) {
        return Err(format!(
            "Draco bitstream version {major}.{minor} is not decoded (only 2.2, what Draco 1.3 \
             and later write)"
        ));
    }
    let encoder_type = r.u8("the header")?;
    let method = r.u8("the header")?;
    let flags = r.u16("the header")?;
    match encoder_type {
        1 => {}
        0 => return Err("a Draco point cloud is not a mesh: not decoded".into()),
        t => {
            return Err(format!(
                "Draco geometry type {t} is not a triangular mesh: not decoded"
            ))
        }
    }
    if flags & 0x8000 != 0 {
        skip_geometry_metadata(&mut r)?;
    }
    let (table, mesh_faces, mesh_points) = match method {
        0 => {
            let (f, p) = sequential::decode(&mut r, faces, points)?;
            (None, f, p)
        }
        1 => {
            let c = edgebreaker::decode(&mut r, faces)?;
            let attributes: Vec<AttributeTable> =
                c.seams.iter().map(|s| attribute_table(&c.table, s)).collect();
            if attributes.iter().any(|a| a.table.vertex.contains(&NONE)) {
                return Err("an attribute seam leaves a corner without a vertex: the file is damaged".into());
            }
            let (corner_to_point, p) = if attributes.is_empty() {
                (c.table.vertex.clone(), c.vertices)
            } else {
                assign_points(&c.table, &c.holes, &attributes)
            };
            let f = corner_to_point
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect();
            let tables = Tables {
                mesh: c.table,
                attributes,
                corner_to_point,
            };
            (Some(tables), f, p)
        }
        m => return Err(format!("Draco mesh encoding {m} is neither sequential (0) nor Edgebreaker (1): the file is damaged")),
    };
    if mesh_faces.len() != faces || mesh_points != points {
        return Err(format!(
            "the Draco data holds {} triangles over {mesh_points} points, but the accessors say \
             {faces} triangles over {points} points",
            mesh_faces.len()
        ));
    }
    let attributes = decode_attributes(&mut r, table.as_ref(), points)?;
    Ok(DracoMesh {
        faces: mesh_faces,
        points,
        attributes,
    })
}

fn decode_attributes(
    r: &mut Reader<'_>,
    tables: Option<&Tables>,
    points: usize,
) -> Decoded<Vec<Attribute>> {
    let groups = usize::from(r.u8("the number of attribute groups")?);
    // Per group: the table its values are stored over, the table its predictions read, and
    // whether it is stored by prediction degree.
    let mut orders: Vec<(Option<&CornerTable>, Option<&CornerTable>, bool)> =
        Vec::with_capacity(groups);
    for _ in 0..groups {
        let Some(t) = tables else {
            orders.push((None, None, false));
            continue;
        };
        let data_id = r.u8("an attribute group")? as i8;
        let per_corner = r.u8("an attribute group")?;
        let traversal = r.u8("an attribute group")?;
        let seams = match usize::try_from(data_id) {
            Ok(i) => Some(
                &t.attributes
                    .get(i)
                    .ok_or("an attribute group names seams that do not exist: the file is damaged")?
                    .table,
            ),
            Err(_) => None,
        };
        if traversal > 1
            || per_corner > 1
            || (per_corner == 1 && (seams.is_none() || traversal != 0))
        {
            return Err(format!(
                "attribute group kind {per_corner} with traversal {traversal} is not valid: the file is damaged"
            ));
        }
        match (per_corner, seams) {
            (1, Some(seams)) => orders.push((Some(seams), Some(seams), false)),
            _ => orders.push((Some(&t.mesh), Some(&t.mesh), traversal == 1)),
        }
    }
    let mut components = 0;
    let mut layouts = Vec::with_capacity(groups);
    for _ in 0..groups {
        layouts.push(read_layouts(r, &mut components)?);
    }
    let mut positions: Option<Positions> = None;
    let mut out = Vec::new();
    for (layouts, (order, predict, by_degree)) in layouts.iter().zip(orders) {
        match (tables, order, predict) {
            (Some(t), Some(order), Some(predict)) => {
                let seq = sequence(order, by_degree, t.corner_to_point.clone());
                let point_to_value = seq
                    .point_to_value(order, points)
                    .ok_or("the traversal does not reach every point: the file is damaged")?;
                let entries = seq.points.len();
                let group = decode_group(
                    r,
                    layouts,
                    entries,
                    &point_to_value,
                    Some((predict, &seq)),
                    &mut positions,
                )?;
                out.extend(group);
            }
            _ => {
                let identity: Vec<u32> = (0..points as u32).collect();
                let group = decode_group(r, layouts, points, &identity, None, &mut positions)?;
                out.extend(group);
            }
        }
    }
    Ok(out)
}

/// Skip the metadata: entries and nested metadata, at most a few levels deep.
fn skip_geometry_metadata(r: &mut Reader<'_>) -> Decoded<()> {
    let attributes = r.count("the metadata", r.remaining())?;
    for _ in 0..attributes {
        r.varint("the metadata")?;
        skip_metadata(r, 0)?;
    }
    skip_metadata(r, 0)
}

fn skip_metadata(r: &mut Reader<'_>, depth: usize) -> Decoded<()> {
    if depth > 16 {
        return Err("metadata nested too deep: the file is damaged".into());
    }
    let entries = r.count("the metadata", r.remaining())?;
    for _ in 0..entries {
        let name = usize::from(r.u8("a metadata name")?);
        r.bytes(name, "a metadata name")?;
        let size = r.count("a metadata value", r.remaining())?;
        r.bytes(size, "a metadata value")?;
    }
    let nested = r.count("the metadata", r.remaining())?;
    for _ in 0..nested {
        let name = usize::from(r.u8("a metadata name")?);
        r.bytes(name, "a metadata name")?;
        skip_metadata(r, depth + 1)?;
    }
    Ok(())
}
