//! Where the generators come from (digest 004 §2.8, §2.10): trivial and statistical
//! synthesis of the ellipses that Lloyd relaxes, and user edits of them before a re-run.
pub mod edits;
pub mod synthesis;
