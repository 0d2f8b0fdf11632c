//! Where the generators come from ([references: frasson §3.5.3, §3.7.1]): trivial and statistical
//! synthesis of the ellipses that Lloyd relaxes, course-by-course synthesis of layered samples,
//! and user edits of the generators before a re-run.
pub mod courses;
pub mod edits;
pub mod synthesis;
