//! The scene: scan readers, the hierarchy builder, the store, the cut and the queries.

mod ascii;
mod corpus;
mod extremes;
mod formats;
mod import_safety;
mod mutations;
mod oracles;
mod store_file;
mod textured_features;
