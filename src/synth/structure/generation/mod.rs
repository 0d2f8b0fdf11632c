//! Where the generators come from ([references: frasson §3.5.3, §3.7.1]): trivial and statistical
//! synthesis of the ellipses that Lloyd relaxes, and user edits of them before a re-run.
pub mod edits;
pub mod synthesis;
