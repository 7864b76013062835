//! Blind judgement of plans by people (`annotate.md` §3): the annotations
//! file that the annotation screen writes and `agree` reads.

pub mod judgements;

pub use judgements::{
    default_annotations_path, export_csv, guidelines_hash, AnnotationWriter, Annotations, Current,
    Judgement, Preference, StepLabel, StepLabelKind, Subject, Verdict, WriteError,
};
