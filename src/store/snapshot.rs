//! HDF5 field snapshots with an XDMF sidecar that ParaView opens: one group `/step_<n>` per snapshot with
//! `coords` (nodes × 2), `quads` (elements × 4, 0-based), one dataset per nodal field (nodes or nodes × 3
//! for vectors, z = 0) and a `time` attribute; the `.xdmf` file has one Grid per snapshot (Topology
//! Quadrilateral, Geometry XY) in a temporal collection and is rewritten after each snapshot, so it is
//! always valid.

use std::path::{Path, PathBuf};

use super::{Result, StoreError};
use crate::observe::FieldSnapshot;

/// Writes the snapshots of one case to `<dir>/<case_hash>.h5` and `<dir>/<case_hash>.xdmf`.
pub struct SnapshotWriter {
    h5: PathBuf,
    xdmf: PathBuf,
    file: hdf5::File,
    grids: Vec<String>,
}

impl SnapshotWriter {
    /// Creates (truncating) the files of case `case_hash` in `dir`.
    pub fn create(dir: &Path, case_hash: &str) -> Result<SnapshotWriter> {
        std::fs::create_dir_all(dir).map_err(|source| StoreError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        let h5 = dir.join(format!("{case_hash}.h5"));
        let xdmf = dir.join(format!("{case_hash}.xdmf"));
        let file = hdf5::File::create(&h5).map_err(|e| StoreError::Hdf5 {
            path: h5.clone(),
            message: e.to_string(),
        })?;
        Ok(SnapshotWriter {
            h5,
            xdmf,
            file,
            grids: Vec::new(),
        })
    }

    /// Reopens the files of an interrupted case that continues after `step`: the snapshots up to
    /// `step` are kept (and listed again in the XDMF file), later ones removed. Without an HDF5
    /// file it creates one.
    pub fn reopen(dir: &Path, case_hash: &str, step: u64) -> Result<SnapshotWriter> {
        let h5 = dir.join(format!("{case_hash}.h5"));
        if !h5.exists() {
            return Self::create(dir, case_hash);
        }
        let h5err = |e: hdf5::Error| StoreError::Hdf5 {
            path: h5.clone(),
            message: e.to_string(),
        };
        let file = hdf5::File::append(&h5).map_err(h5err)?;
        let mut w = SnapshotWriter {
            xdmf: dir.join(format!("{case_hash}.xdmf")),
            file,
            grids: Vec::new(),
            h5: h5.clone(),
        };
        let mut names = w.file.member_names().map_err(h5err)?;
        names.sort();
        for name in names {
            let Some(s) = name
                .strip_prefix("step_")
                .and_then(|n| n.parse::<u64>().ok())
            else {
                continue;
            };
            if s > step {
                w.file.unlink(&name).map_err(h5err)?;
                continue;
            }
            let g = w.file.group(&name).map_err(h5err)?;
            let t: f64 = g
                .attr("time")
                .and_then(|a| a.read_scalar())
                .map_err(h5err)?;
            let n = g.dataset("coords").map_err(h5err)?.shape()[0];
            let ne = g.dataset("quads").map_err(h5err)?.shape()[0];
            let mut fields = Vec::new();
            for f in g.member_names().map_err(h5err)? {
                if f != "coords" && f != "quads" {
                    let shape = g.dataset(&f).map_err(h5err)?.shape();
                    fields.push((f, if shape.len() == 1 { 1 } else { 3 }));
                }
            }
            let grid = w.grid_xml(&name, t, n, ne, &fields);
            w.grids.push(grid);
        }
        w.file.flush().map_err(h5err)?;
        w.write_xdmf()?;
        Ok(w)
    }

    /// The XDMF Grid of one snapshot group with its fields (name, 1 or 3 components).
    fn grid_xml(
        &self,
        name: &str,
        t: f64,
        n: usize,
        ne: usize,
        fields: &[(String, usize)],
    ) -> String {
        let h5_name = self
            .h5
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let attrs: String = fields
            .iter()
            .map(|(f, c)| {
                let (dims, kind) = if *c == 1 {
                    (format!("{n}"), "Scalar")
                } else {
                    (format!("{n} 3"), "Vector")
                };
                format!(
                    "        <Attribute Name=\"{f}\" AttributeType=\"{kind}\" Center=\"Node\">\n          <DataItem Dimensions=\"{dims}\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{h5_name}:/{name}/{f}</DataItem>\n        </Attribute>\n"
                )
            })
            .collect();
        format!(
            "      <Grid Name=\"{name}\" GridType=\"Uniform\">\n        <Time Value=\"{t}\"/>\n        <Topology TopologyType=\"Quadrilateral\" NumberOfElements=\"{ne}\">\n          <DataItem Dimensions=\"{ne} 4\" NumberType=\"UInt\" Precision=\"8\" Format=\"HDF\">{h5_name}:/{name}/quads</DataItem>\n        </Topology>\n        <Geometry GeometryType=\"XY\">\n          <DataItem Dimensions=\"{n} 2\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{h5_name}:/{name}/coords</DataItem>\n        </Geometry>\n{attrs}      </Grid>\n"
        )
    }

    /// Rewrites the XDMF file listing every snapshot so far (write-then-rename, so a reader never
    /// sees a half-written sidecar).
    fn write_xdmf(&self) -> Result<()> {
        let xml = format!(
            "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n    <Grid Name=\"snapshots\" GridType=\"Collection\" CollectionType=\"Temporal\">\n{}    </Grid>\n  </Domain>\n</Xdmf>\n",
            self.grids.concat()
        );
        let tmp = self.xdmf.with_extension("xdmf.tmp");
        std::fs::write(&tmp, xml)
            .and_then(|_| std::fs::rename(&tmp, &self.xdmf))
            .map_err(|source| StoreError::Io {
                path: self.xdmf.clone(),
                source,
            })
    }

    /// The HDF5 file.
    pub fn h5_path(&self) -> &Path {
        &self.h5
    }

    /// The XDMF file.
    pub fn xdmf_path(&self) -> &Path {
        &self.xdmf
    }

    /// Appends one snapshot and rewrites the XDMF file.
    ///
    /// # Panics
    /// If a field's length is not `components × nodes` (a broken contract of the runner).
    pub fn write(&mut self, s: &FieldSnapshot) -> Result<()> {
        let h5err = |e: hdf5::Error| StoreError::Hdf5 {
            path: self.h5.clone(),
            message: e.to_string(),
        };
        let name = format!("step_{:010}", s.step);
        let g = self.file.create_group(&name).map_err(h5err)?;
        let n = s.coords.len();
        let coords: Vec<f64> = s.coords.iter().flat_map(|c| *c).collect();
        let quads: Vec<u64> = s.quads.iter().flat_map(|q| q.map(|i| i as u64)).collect();
        g.new_dataset::<f64>()
            .shape([n, 2])
            .create("coords")
            .and_then(|d| d.write_raw(&coords))
            .map_err(h5err)?;
        g.new_dataset::<u64>()
            .shape([s.quads.len(), 4])
            .create("quads")
            .and_then(|d| d.write_raw(&quads))
            .map_err(h5err)?;
        g.new_attr::<f64>()
            .create("time")
            .and_then(|a| a.write_scalar(&s.t))
            .map_err(h5err)?;
        let mut fields = Vec::with_capacity(s.fields.len());
        for f in &s.fields {
            assert_eq!(
                f.values.len(),
                f.components * n,
                "field {} has the wrong length",
                f.name
            );
            let (values, shape) = if f.components == 1 {
                (f.values.clone(), vec![n])
            } else {
                let v: Vec<f64> = f
                    .values
                    .chunks(f.components)
                    .flat_map(|c| [c[0], c.get(1).copied().unwrap_or(0.0), 0.0])
                    .collect();
                (v, vec![n, 3])
            };
            g.new_dataset::<f64>()
                .shape(shape)
                .create(f.name.as_str())
                .and_then(|d| d.write_raw(&values))
                .map_err(h5err)?;
            fields.push((f.name.clone(), if f.components == 1 { 1 } else { 3 }));
        }
        self.file.flush().map_err(h5err)?;
        let grid = self.grid_xml(&name, s.t, n, s.quads.len(), &fields);
        self.grids.push(grid);
        self.write_xdmf()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::NodalField;

    #[test]
    fn snapshots_read_back_and_xdmf_points_at_them() {
        let dir = std::env::temp_dir().join(format!("xpflow-snap-{}", std::process::id()));
        let mut w = SnapshotWriter::create(&dir, "abc").unwrap();
        for step in [10, 20] {
            let s = FieldSnapshot {
                step,
                t: step as f64 * 0.1,
                coords: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
                quads: vec![[0, 1, 2, 3]],
                fields: vec![
                    NodalField {
                        name: "p".into(),
                        components: 1,
                        values: vec![1.0, 2.0, 3.0, step as f64],
                    },
                    NodalField {
                        name: "u".into(),
                        components: 2,
                        values: vec![0.5; 8],
                    },
                ],
            };
            w.write(&s).unwrap();
        }
        let f = hdf5::File::open(w.h5_path()).unwrap();
        let p: Vec<f64> = f.dataset("step_0000000020/p").unwrap().read_raw().unwrap();
        assert_eq!(p, vec![1.0, 2.0, 3.0, 20.0]);
        let u = f.dataset("step_0000000010/u").unwrap();
        assert_eq!(u.shape(), vec![4, 3]);
        let q: Vec<u64> = f
            .dataset("step_0000000010/quads")
            .unwrap()
            .read_raw()
            .unwrap();
        assert_eq!(q, vec![0, 1, 2, 3]);
        let t: f64 = f
            .group("step_0000000020")
            .unwrap()
            .attr("time")
            .unwrap()
            .read_scalar()
            .unwrap();
        assert!((t - 2.0).abs() < 1e-12);
        let xml = std::fs::read_to_string(w.xdmf_path()).unwrap();
        assert_eq!(xml.matches("<Grid Name=\"step_").count(), 2);
        assert!(
            xml.contains("TopologyType=\"Quadrilateral\"") && xml.contains("GeometryType=\"XY\"")
        );
        assert!(xml.contains("abc.h5:/step_0000000020/p"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
