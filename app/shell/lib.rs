//! The imperative shell of IsoKiosk: the kiosk's windows, its clock and terminal (the import's
//! progress bar and signals), and the statistics report. It feeds the pure core (`kiosk-core`) with what `kiosk-content` reads from
//! disk (stores, exhibits, media, narration).

pub mod report;
pub mod terminal;
pub mod windows;
