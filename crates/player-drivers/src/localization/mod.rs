//! Localization drivers (Player's `server/drivers/localization/`): `amcl`.

pub mod amcl;
