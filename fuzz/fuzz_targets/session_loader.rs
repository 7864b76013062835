//! The session loader on any file: it never panics, and a session it
//! accepts is saved and read back unchanged (a session that loads once must
//! load again after the workbench saves it, or the user's work is set aside).
#![no_main]

use libfuzzer_sys::fuzz_target;
use mapvlm::workbench::session::decode;

fuzz_target!(|bytes: &[u8]| {
    let Ok((session, _)) = decode(bytes) else {
        return;
    };
    let saved = serde_json::to_vec_pretty(&session).unwrap_or_else(|e| panic!("{e}"));
    let (again, repaired) = decode(&saved)
        .unwrap_or_else(|reason| panic!("a loaded session does not load after saving: {reason}"));
    assert_eq!(again, session);
    assert!(repaired.is_empty(), "a saved session needs repair: {repaired:?}");
});
