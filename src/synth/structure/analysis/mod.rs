//! Reading a structure sample: importing it from a label image, fitting its regions'
//! ellipses and measuring the statistics synthesis samples from ([references: frasson §3.1, §3.4]), and
//! comparing two such measurements (the report); the courses of a layered sample.
pub mod courses;
pub mod ellipse;
pub mod labels_import;
pub mod report;
pub mod sample;
pub mod stats;
