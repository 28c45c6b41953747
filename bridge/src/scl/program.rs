//! What the player and the console ask of MOONS' drives, as sequences of requests on
//! an [`SclLink`](super::SclLink): a console line resolved to its drives
//! ([`console_targets`]), and a Q program's segments written with `QW` and read back
//! with `QU` ([`upload`]).
