//! The DDS participant, configured from ROS 2's environment: ros2-client reads none of it
//! (its `Context::new` is always domain 0, discovering on every interface).

use std::net::{IpAddr, Ipv4Addr};

use ros2_client::Context;
use ros2_client::dds::rustdds::DomainParticipantBuilder;

use crate::Error;

/// Where the node discovers peers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Discovery {
    /// `ROS_DOMAIN_ID` (0 when unset or empty).
    pub domain_id: u16,
    /// Loopback only: `ROS_LOCALHOST_ONLY=1` (Humble) or
    /// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (Iron and later).
    pub localhost_only: bool,
}

/// The highest domain id whose RTPS ports fit in 16 bits (ROS 2 documents 0..=232 on Linux).
const MAX_DOMAIN_ID: u16 = 232;

impl Discovery {
    /// Reads `ROS_DOMAIN_ID`, `ROS_LOCALHOST_ONLY` and `ROS_AUTOMATIC_DISCOVERY_RANGE` through
    /// `var`; a domain id that is not a number in 0..=232 is an error naming the variable.
    pub fn from_vars(var: impl Fn(&str) -> Option<String>) -> Result<Discovery, Error> {
        let domain_id = match var("ROS_DOMAIN_ID").map(|v| v.trim().to_string()) {
            None => 0,
            Some(v) if v.is_empty() => 0,
            Some(v) => v
                .parse::<u16>()
                .ok()
                .filter(|d| *d <= MAX_DOMAIN_ID)
                .ok_or_else(|| Error::Environment {
                    variable: "ROS_DOMAIN_ID",
                    message: format!("`{v}` is not a domain id (0 to {MAX_DOMAIN_ID})"),
                })?,
        };
        let localhost_only = var("ROS_LOCALHOST_ONLY").is_some_and(|v| v.trim() == "1")
            || var("ROS_AUTOMATIC_DISCOVERY_RANGE")
                .is_some_and(|v| v.trim().eq_ignore_ascii_case("LOCALHOST"));
        Ok(Discovery {
            domain_id,
            localhost_only,
        })
    }

    /// [`Discovery::from_vars`] on the process environment.
    pub fn from_env() -> Result<Discovery, Error> {
        Discovery::from_vars(|k| std::env::var(k).ok())
    }

    /// A ros2-client context on a participant in this domain, restricted to the loopback
    /// interface when localhost-only.
    pub fn context(&self) -> Result<Context, Error> {
        let mut builder = DomainParticipantBuilder::new(self.domain_id);
        if self.localhost_only {
            builder = builder.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        }
        let participant = builder
            .build()
            .map_err(|e| Error::Dds(format!("creating the DDS participant: {e}")))?;
        Context::from_domain_participant(participant)
            .map_err(|e| Error::Dds(format!("creating the ROS 2 context: {e}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vars<'a>(pairs: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |k| {
            pairs
                .iter()
                .find(|(n, _)| *n == k)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn ros_environment() {
        let d = Discovery::from_vars(vars(&[])).unwrap();
        assert_eq!((d.domain_id, d.localhost_only), (0, false));
        let d = Discovery::from_vars(vars(&[
            ("ROS_DOMAIN_ID", "42"),
            ("ROS_LOCALHOST_ONLY", "1"),
        ]));
        assert_eq!(
            d.unwrap(),
            Discovery {
                domain_id: 42,
                localhost_only: true
            }
        );
        let d = Discovery::from_vars(vars(&[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")]));
        assert!(d.unwrap().localhost_only);
        let d = Discovery::from_vars(vars(&[("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET")]));
        assert!(!d.unwrap().localhost_only);
        assert_eq!(
            Discovery::from_vars(vars(&[("ROS_DOMAIN_ID", "")]))
                .unwrap()
                .domain_id,
            0
        );
        for bad in ["233", "-1", "x"] {
            let e = Discovery::from_vars(vars(&[("ROS_DOMAIN_ID", bad)])).unwrap_err();
            assert!(e.to_string().contains("ROS_DOMAIN_ID"), "{e}");
        }
    }
}
