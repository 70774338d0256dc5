//! Results store: SQLite tables and HDF5 field snapshots.
