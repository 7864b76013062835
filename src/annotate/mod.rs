//! Blind judgement of plans by people (`annotate.md` §3): the annotations
//! file that the annotation screen writes and `agree` reads, the guidelines
//! annotators judge by, and the order each of them sees the items in.

pub mod guidelines;
pub mod judgements;
pub mod order;
pub mod skips;

pub use judgements::{
    default_annotations_path, export_csv, guidelines_hash, AnnotationWriter, Annotations, Current,
    Judgement, Preference, StepLabel, StepLabelKind, Subject, Verdict, WriteError,
};
