//! The two declarations everything else is generated from.
//!
//! * `xdr_struct!` — one description per C struct gives the Rust struct, its XDR encoder and
//!   decoder, its field-map view and (in tests) a proptest strategy.
//! * `message_table!` — upstream's (interface, type, subtype) → struct function table, written
//!   once; it gives the typed message enums, the decoder dispatch, the encoder and the row list.

/// Declares message structs.
///
/// ```text
/// /// doc
/// pub struct DeviceReq = "player_device_req_t" {
///     /// doc
///     addr: DeviceAddr,
///     access: u8,
///     driver_name: Text [max PLAYER_MAX_DRIVER_STRING_LEN],
///     kind ("type"): u8,        // Rust name differs from the C member name
/// }
/// ```
///
/// Members are encoded in declaration order. A `Vec`/`Text` member stands for the C pair
/// `uint32_t x_count; T *x;` (or `T x[N]` with `[max N]`).
macro_rules! xdr_struct {
    (@cname $field:ident) => { stringify!($field) };
    (@cname $field:ident $cname:literal) => { $cname };

    (@decode $r:ident, $fty:ty) => { <$fty as $crate::xdr::Xdr>::decode($r) };
    (@decode $r:ident, $fty:ty, $max:expr) => {
        <$fty as $crate::xdr::Counted>::decode_max($r, $max)
    };

    (@encode $v:expr, $out:ident, $fty:ty) => { <$fty as $crate::xdr::Xdr>::encode($v, $out) };
    (@encode $v:expr, $out:ident, $fty:ty, $max:expr) => {
        <$fty as $crate::xdr::Counted>::encode_max($v, $max, $out)
    };

    (@arb $fty:ty) => { <$fty as $crate::xdr::Xdr>::arbitrary() };
    (@arb $fty:ty, $max:expr) => { <$fty as $crate::xdr::Counted>::arbitrary_max($max) };

    ($(
        $(#[$attr:meta])*
        pub struct $name:ident = $cname:literal {
            $(
                $(#[$fattr:meta])*
                $field:ident $(($fcname:literal))? : $fty:ty $([max $max:expr])?
            ),+ $(,)?
        }
    )*) => {$(
        $(#[$attr])*
        #[doc = ""]
        #[doc = concat!("C struct `", $cname, "`.")]
        #[derive(Clone, Debug, Default, PartialEq)]
        pub struct $name {
            $(
                $(#[$fattr])*
                pub $field: $fty,
            )+
        }

        impl $crate::xdr::XdrStruct for $name {
            const C_NAME: &'static str = $cname;
        }

        impl $crate::xdr::Elem for $name {}

        impl $crate::xdr::Xdr for $name {
            const MIN_SIZE: usize = 0 $(+ <$fty as $crate::xdr::Xdr>::MIN_SIZE)+;

            fn encode(&self, out: &mut Vec<u8>) -> Result<(), $crate::Error> {
                $(
                    xdr_struct!(@encode &self.$field, out, $fty $(, $max)?).map_err(|e| {
                        e.locate($cname, xdr_struct!(@cname $field $($fcname)?))
                    })?;
                )+
                Ok(())
            }

            fn decode(r: &mut $crate::xdr::Reader<'_>) -> Result<Self, $crate::Error> {
                Ok($name {
                    $(
                        $field: xdr_struct!(@decode r, $fty $(, $max)?).map_err(|e| {
                            e.locate($cname, xdr_struct!(@cname $field $($fcname)?))
                        })?,
                    )+
                })
            }

            fn to_value(&self) -> $crate::Value {
                let mut members = Vec::new();
                $(
                    <$fty as $crate::xdr::Xdr>::put_member(
                        &self.$field,
                        xdr_struct!(@cname $field $($fcname)?),
                        &mut members,
                    );
                )+
                $crate::Value::Struct(members)
            }

            fn from_value(v: &$crate::Value) -> Result<Self, $crate::Error> {
                let members = v.members().map_err(|e| e.locate($cname, ""))?;
                Ok($name {
                    $(
                        $field: <$fty as $crate::xdr::Xdr>::take_member(
                            xdr_struct!(@cname $field $($fcname)?),
                            members,
                        )
                        .map_err(|e| e.locate($cname, xdr_struct!(@cname $field $($fcname)?)))?,
                    )+
                })
            }

            #[cfg(test)]
            fn arbitrary() -> proptest::strategy::BoxedStrategy<Self> {
                use proptest::strategy::Strategy;
                ( $( xdr_struct!(@arb $fty $(, $max)?), )+ )
                    .prop_map(|( $($field,)+ )| $name { $($field),+ })
                    .boxed()
            }
        }
    )*};
}

/// Ignores its first argument: lets a `$(...)?` group that must mention a metavariable emit
/// code that does not otherwise need it.
macro_rules! skip_first {
    ($ignored:ident; $($t:tt)*) => { $($t)* };
}

/// One kind (DATA, CMD, REQ or SYNCH) of one interface: an enum with a variant per subtype.
///
/// REQ variants hold `Option<Struct>`: clients send "null requests" (GET_GEOM, ...) without a
/// body, replies may or may not carry one, and the server must tell the cases apart (Stage NACKs
/// a GET_GEOM that has a body). DATA, CMD and SYNCH variants hold the struct itself; such a
/// message without its body is refused at decode time.
macro_rules! kind_enum {
    (@payload req $sty:ty) => { Option<$sty> };
    (@payload $kind:ident $sty:ty) => { $sty };

    (@cname [$code:ident $kindname:ident] $name:ident) => {
        concat!("PLAYER_", stringify!($code), "_", stringify!($kindname), "_", stringify!($name))
    };
    (@cname [] $name:ident) => { stringify!($name) };

    (@struct_name) => { None };
    (@struct_name $sty:ty) => { Some(<$sty as $crate::xdr::XdrStruct>::C_NAME) };

    (@bind $p:ident $sty:ty) => { $p };

    (@read req $key:ident $src:ident $var:ident) => {
        if $src.has_body() {
            Err($crate::Error::UnexpectedBody { key: $key })
        } else {
            Ok(Self::$var)
        }
    };
    (@read req $key:ident $src:ident $var:ident $sty:ty) => {
        if $src.has_body() {
            Ok(Self::$var(Some($src.get::<$sty>()?)))
        } else {
            Ok(Self::$var(None))
        }
    };
    (@read $kind:ident $key:ident $src:ident $var:ident) => {
        if $src.has_body() {
            Err($crate::Error::UnexpectedBody { key: $key })
        } else {
            Ok(Self::$var)
        }
    };
    (@read $kind:ident $key:ident $src:ident $var:ident $sty:ty) => {
        if $src.has_body() {
            Ok(Self::$var($src.get::<$sty>()?))
        } else {
            Err($crate::Error::MissingBody { key: $key })
        }
    };

    (@write req $sink:ident $p:ident $sty:ty) => {
        if let Some(body) = $p {
            $sink.put::<$sty>(body)?;
        }
    };
    (@write $kind:ident $sink:ident $p:ident $sty:ty) => {
        $sink.put::<$sty>($p)?;
    };

    (@arb req $var:ident) => { proptest::strategy::Just(Self::$var).boxed() };
    (@arb req $var:ident $sty:ty) => {
        proptest::prop_oneof![
            proptest::strategy::Just(Self::$var(None)),
            <$sty as $crate::xdr::Xdr>::arbitrary().prop_map(|s| Self::$var(Some(s))),
        ]
        .boxed()
    };
    (@arb $kind:ident $var:ident) => { proptest::strategy::Just(Self::$var).boxed() };
    (@arb $kind:ident $var:ident $sty:ty) => {
        <$sty as $crate::xdr::Xdr>::arbitrary().prop_map(Self::$var).boxed()
    };

    ($kind:ident $cn:tt $(#[$attr:meta])* $enum:ident {
        $( $sub:literal $name:ident $var:ident $(($sty:ty))? ),+ $(,)?
    }) => {
        $(#[$attr])*
        #[derive(Clone, Debug, PartialEq)]
        pub enum $enum {
            $(
                #[doc = concat!("`", kind_enum!(@cname $cn $name), "` (subtype ", $sub, ").")]
                $var $( (kind_enum!(@payload $kind $sty)) )?,
            )+
        }

        #[allow(dead_code)]
        impl $enum {
            $(
                #[doc = concat!("Subtype of `", kind_enum!(@cname $cn $name), "`.")]
                pub const $name: u8 = $sub;
            )+

            /// Every subtype of this kind: (subtype, C constant, body struct or `None`).
            pub const ROWS: &'static [(u8, &'static str, Option<&'static str>)] = &[
                $( ($sub, kind_enum!(@cname $cn $name), kind_enum!(@struct_name $($sty)?)), )+
            ];

            /// The subtype byte of this message.
            pub fn subtype(&self) -> u8 {
                match self {
                    $( Self::$var { .. } => $sub, )+
                }
            }

            /// The C constant of this message's subtype.
            pub fn constant(&self) -> &'static str {
                match self {
                    $( Self::$var { .. } => kind_enum!(@cname $cn $name), )+
                }
            }

            /// The C struct of the body this subtype's row declares (`None` for `NULL`).
            pub fn row_struct(&self) -> Option<&'static str> {
                match self {
                    $( Self::$var { .. } => kind_enum!(@struct_name $($sty)?), )+
                }
            }

            pub(crate) fn has_subtype(subtype: u8) -> bool {
                Self::ROWS.iter().any(|row| row.0 == subtype)
            }

            pub(crate) fn read<S: $crate::message::BodySource>(
                key: $crate::MessageKey,
                src: &mut S,
            ) -> Result<Self, $crate::Error> {
                match key.subtype {
                    $( $sub => kind_enum!(@read $kind key src $var $($sty)?), )+
                    _ => Err($crate::Error::UnknownMessage(key)),
                }
            }

            #[allow(unused_variables)] // kinds whose rows all lack a body
            pub(crate) fn write<S: $crate::message::BodySink>(
                &self,
                sink: &mut S,
            ) -> Result<(), $crate::Error> {
                match self {
                    $(
                        Self::$var $( (kind_enum!(@bind payload $sty)) )? => {
                            $( kind_enum!(@write $kind sink payload $sty); )?
                        }
                    )+
                }
                Ok(())
            }

            #[cfg(test)]
            pub(crate) fn arbitrary_rows()
                -> Vec<(u8, proptest::strategy::BoxedStrategy<Self>)>
            {
                use proptest::strategy::Strategy;
                vec![ $( ($sub, kind_enum!(@arb $kind $var $($sty)?)), )+ ]
            }
        }
    };
}

/// `From<$from> for Body`: wraps the value in the interface's message enum variant `$wrap`
/// (none for the message enum itself) and that in `Body::$iface`.
macro_rules! body_from {
    ($from:ty => $iface:ident) => {
        impl From<$from> for Body {
            fn from(m: $from) -> Body {
                Body::$iface(m)
            }
        }
    };
    ($(#[$attr:meta])* $from:ty => $iface:ident($wrap:path)) => {
        $(#[$attr])*
        impl From<$from> for Body {
            fn from(m: $from) -> Body {
                Body::$iface($wrap(m))
            }
        }
    };
}

/// The function table: one section per interface, one row per message.
macro_rules! message_table {
    (
        $(#[$uattr:meta])*
        universal $uenum:ident ($umsg:ident) { $($urows:tt)* }
        $(
            $(#[$iattr:meta])*
            interface $iface:ident ($imsg:ident) = $code:ident {
                $( data $denum:ident { $($drows:tt)* } )?
                $( cmd $cenum:ident { $($crows:tt)* } )?
                $( req $renum:ident { $($rrows:tt)* } )?
                $( synch $senum:ident { $($srows:tt)* } )?
            }
        )+
    ) => {
        kind_enum! { req []
            $(#[$uattr])*
            $uenum { $($urows)* }
        }

        /// A universal request or its reply (valid on every interface; the header carries the
        /// target device's own interface code).
        #[derive(Clone, Debug, PartialEq)]
        pub enum $umsg {
            /// `PLAYER_MSGTYPE_REQ`.
            Req($uenum),
            /// `PLAYER_MSGTYPE_RESP_ACK`.
            Ack($uenum),
            /// `PLAYER_MSGTYPE_RESP_NACK`.
            Nack($uenum),
        }

        impl $umsg {
            /// The message type of this message.
            pub fn msg_type(&self) -> MsgType {
                match self {
                    Self::Req(_) => MsgType::Req,
                    Self::Ack(_) => MsgType::RespAck,
                    Self::Nack(_) => MsgType::RespNack,
                }
            }

            fn kind(&self) -> &$uenum {
                match self {
                    Self::Req(k) | Self::Ack(k) | Self::Nack(k) => k,
                }
            }

            fn read<S: BodySource>(t: MsgType, key: MessageKey, src: &mut S) -> Result<Self, Error> {
                match t {
                    MsgType::Req => $uenum::read(key, src).map(Self::Req),
                    MsgType::RespAck => $uenum::read(key, src).map(Self::Ack),
                    MsgType::RespNack => $uenum::read(key, src).map(Self::Nack),
                    _ => Err(Error::UnknownMessage(key)),
                }
            }
        }

        $(
            $( kind_enum! { data [$code DATA]
                #[doc = concat!("DATA messages of interface `PLAYER_", stringify!($code), "_CODE`.")]
                $denum { $($drows)* }
            } )?
            $( kind_enum! { cmd [$code CMD]
                #[doc = concat!("CMD messages of interface `PLAYER_", stringify!($code), "_CODE`.")]
                $cenum { $($crows)* }
            } )?
            $( kind_enum! { req [$code REQ]
                #[doc = concat!("REQ subtypes of interface `PLAYER_", stringify!($code), "_CODE` ")]
                #[doc = "(requests, and their ACK/NACK replies, which use the same body struct)."]
                $renum { $($rrows)* }
            } )?
            $( kind_enum! { synch [$code SYNCH]
                #[doc = concat!("SYNCH messages of interface `PLAYER_", stringify!($code), "_CODE`.")]
                $senum { $($srows)* }
            } )?

            $(#[$iattr])*
            #[derive(Clone, Debug, PartialEq)]
            pub enum $imsg {
                $(
                    /// `PLAYER_MSGTYPE_DATA` (server → client).
                    Data($denum),
                )?
                $(
                    /// `PLAYER_MSGTYPE_CMD` (client → server, never answered).
                    Cmd($cenum),
                )?
                $(
                    /// `PLAYER_MSGTYPE_REQ` (client → server).
                    Req($renum),
                    /// `PLAYER_MSGTYPE_RESP_ACK` to a request of this subtype.
                    Ack($renum),
                    /// `PLAYER_MSGTYPE_RESP_NACK` to a request of this subtype.
                    Nack($renum),
                )?
                $(
                    /// `PLAYER_MSGTYPE_SYNCH` (end of a PULL round).
                    Synch($senum),
                )?
            }

            impl $imsg {
                /// The interface these messages belong to.
                pub const INTERFACE: InterfaceCode = InterfaceCode::$code;

                /// The message type of this message.
                pub fn msg_type(&self) -> MsgType {
                    match self {
                        $( Self::Data(_) => skip_first!($denum; MsgType::Data), )?
                        $( Self::Cmd(_) => skip_first!($cenum; MsgType::Cmd), )?
                        $(
                            Self::Req(_) => skip_first!($renum; MsgType::Req),
                            Self::Ack(_) => MsgType::RespAck,
                            Self::Nack(_) => MsgType::RespNack,
                        )?
                        $( Self::Synch(_) => skip_first!($senum; MsgType::Synch), )?
                    }
                }

                /// The subtype byte of this message.
                pub fn subtype(&self) -> u8 {
                    match self {
                        $( Self::Data(k) => skip_first!($denum; k.subtype()), )?
                        $( Self::Cmd(k) => skip_first!($cenum; k.subtype()), )?
                        $( Self::Req(k) | Self::Ack(k) | Self::Nack(k) => skip_first!($renum; k.subtype()), )?
                        $( Self::Synch(k) => skip_first!($senum; k.subtype()), )?
                    }
                }

                /// The C constant of this message's subtype.
                pub fn constant(&self) -> &'static str {
                    match self {
                        $( Self::Data(k) => skip_first!($denum; k.constant()), )?
                        $( Self::Cmd(k) => skip_first!($cenum; k.constant()), )?
                        $( Self::Req(k) | Self::Ack(k) | Self::Nack(k) => skip_first!($renum; k.constant()), )?
                        $( Self::Synch(k) => skip_first!($senum; k.constant()), )?
                    }
                }

                /// The C struct this message's row declares (`None` for `NULL`).
                pub fn row_struct(&self) -> Option<&'static str> {
                    match self {
                        $( Self::Data(k) => skip_first!($denum; k.row_struct()), )?
                        $( Self::Cmd(k) => skip_first!($cenum; k.row_struct()), )?
                        $( Self::Req(k) | Self::Ack(k) | Self::Nack(k) => skip_first!($renum; k.row_struct()), )?
                        $( Self::Synch(k) => skip_first!($senum; k.row_struct()), )?
                    }
                }

                fn read<S: BodySource>(t: MsgType, key: MessageKey, src: &mut S) -> Result<Self, Error> {
                    match t {
                        $( MsgType::Data => $denum::read(key, src).map(Self::Data), )?
                        $( MsgType::Cmd => $cenum::read(key, src).map(Self::Cmd), )?
                        $(
                            MsgType::Req => $renum::read(key, src).map(Self::Req),
                            MsgType::RespAck => $renum::read(key, src).map(Self::Ack),
                            MsgType::RespNack => $renum::read(key, src).map(Self::Nack),
                        )?
                        $( MsgType::Synch => $senum::read(key, src).map(Self::Synch), )?
                        #[allow(unreachable_patterns)]
                        _ => Err(Error::UnknownMessage(key)),
                    }
                }

                fn write<S: BodySink>(&self, sink: &mut S) -> Result<(), Error> {
                    match self {
                        $( Self::Data(k) => skip_first!($denum; k.write(sink)), )?
                        $( Self::Cmd(k) => skip_first!($cenum; k.write(sink)), )?
                        $( Self::Req(k) | Self::Ack(k) | Self::Nack(k) => skip_first!($renum; k.write(sink)), )?
                        $( Self::Synch(k) => skip_first!($senum; k.write(sink)), )?
                    }
                }

                fn push_rows(rows: &mut Vec<MessageRow>) {
                    $( push_kind_rows(rows, InterfaceCode::$code, MsgType::Data, $denum::ROWS); )?
                    $( push_kind_rows(rows, InterfaceCode::$code, MsgType::Cmd, $cenum::ROWS); )?
                    $( push_kind_rows(rows, InterfaceCode::$code, MsgType::Req, $renum::ROWS); )?
                    $( push_kind_rows(rows, InterfaceCode::$code, MsgType::Synch, $senum::ROWS); )?
                }

                #[cfg(test)]
                fn arbitrary_rows() -> Vec<(String, proptest::strategy::BoxedStrategy<Self>)> {
                    use proptest::strategy::Strategy;
                    #[allow(unused_mut)]
                    let mut rows = Vec::new();
                    $(
                        for (sub, s) in $denum::arbitrary_rows() {
                            rows.push((format!("{} DATA {sub}", stringify!($iface)), s.prop_map(Self::Data).boxed()));
                        }
                    )?
                    $(
                        for (sub, s) in $cenum::arbitrary_rows() {
                            rows.push((format!("{} CMD {sub}", stringify!($iface)), s.prop_map(Self::Cmd).boxed()));
                        }
                    )?
                    $(
                        for (sub, s) in $renum::arbitrary_rows() {
                            let s = (0u8..3, s).prop_map(|(k, r)| match k {
                                0 => Self::Req(r),
                                1 => Self::Ack(r),
                                _ => Self::Nack(r),
                            });
                            rows.push((format!("{} REQ/ACK/NACK {sub}", stringify!($iface)), s.boxed()));
                        }
                    )?
                    $(
                        for (sub, s) in $senum::arbitrary_rows() {
                            rows.push((format!("{} SYNCH {sub}", stringify!($iface)), s.prop_map(Self::Synch).boxed()));
                        }
                    )?
                    rows
                }
            }

            body_from!($imsg => $iface);
            $( body_from!($denum => $iface($imsg::Data)); )?
            $( body_from!($cenum => $iface($imsg::Cmd)); )?
            $(
                body_from!(
                    /// A REQ converts to the request itself; build ACK/NACK replies explicitly.
                    $renum => $iface($imsg::Req)
                );

                impl $renum {
                    /// The request a reply body of this interface answers: an ACK's (what a
                    /// server delivers), or the same request in its REQ form, which is what a
                    /// reply made from the request with `into()` is (as drivers' tests hand
                    /// them). `None` for a NACK, which answers nothing, and for any other body.
                    /// One accessor for every reader of a device's answer that takes both.
                    pub fn in_reply(body: &Body) -> Option<&$renum> {
                        match body {
                            Body::$iface($imsg::Req(r) | $imsg::Ack(r)) => Some(r),
                            _ => None,
                        }
                    }
                }
            )?
            $( body_from!($senum => $iface($imsg::Synch)); )?
        )+

        /// A typed message body: which message it is (interface, type, subtype) and its struct.
        ///
        /// Universal requests come first because upstream's table lists them first and they
        /// match every interface code.
        #[derive(Clone, Debug, PartialEq)]
        pub enum Body {
            /// Universal requests (capabilities, properties) and their replies, any interface.
            Universal($umsg),
            $(
                #[doc = concat!("Interface `", stringify!($code), "`.")]
                $iface($imsg),
            )+
        }

        impl Body {
            /// The interface the body belongs to; `None` for universal requests, which travel
            /// with the target device's interface code.
            pub fn interface(&self) -> Option<InterfaceCode> {
                match self {
                    Body::Universal(_) => None,
                    $( Body::$iface(_) => Some(InterfaceCode::$code), )+
                }
            }

            /// The message type this body is sent as.
            pub fn msg_type(&self) -> MsgType {
                match self {
                    Body::Universal(m) => m.msg_type(),
                    $( Body::$iface(m) => m.msg_type(), )+
                }
            }

            /// The subtype byte this body is sent with.
            pub fn subtype(&self) -> u8 {
                match self {
                    Body::Universal(m) => m.kind().subtype(),
                    $( Body::$iface(m) => m.subtype(), )+
                }
            }

            /// The C constant of the subtype, e.g. `PLAYER_POSITION2D_CMD_VEL`.
            pub fn constant(&self) -> &'static str {
                match self {
                    Body::Universal(m) => m.kind().constant(),
                    $( Body::$iface(m) => m.constant(), )+
                }
            }

            /// The C struct of this message's table row (`None` where the `.def` says `NULL`).
            /// A request sent without its body still names the row's struct here.
            pub fn row_struct(&self) -> Option<&'static str> {
                match self {
                    Body::Universal(m) => m.kind().row_struct(),
                    $( Body::$iface(m) => m.row_struct(), )+
                }
            }

            pub(crate) fn read<S: BodySource>(key: MessageKey, src: &mut S) -> Result<Body, Error> {
                let t = MsgType::from_u8(key.msg_type).ok_or(Error::UnknownMsgType(key.msg_type))?;
                if matches!(t, MsgType::Req | MsgType::RespAck | MsgType::RespNack)
                    && $uenum::has_subtype(key.subtype)
                {
                    return $umsg::read(t, key, src).map(Body::Universal);
                }
                match key.interf {
                    $( InterfaceCode::$code => $imsg::read(t, key, src).map(Body::$iface), )+
                    _ => Err(Error::UnknownMessage(key)),
                }
            }

            pub(crate) fn write<S: BodySink>(&self, sink: &mut S) -> Result<(), Error> {
                match self {
                    Body::Universal(m) => m.kind().write(sink),
                    $( Body::$iface(m) => m.write(sink), )+
                }
            }

            #[cfg(test)]
            pub(crate) fn arbitrary_rows() -> Vec<(String, proptest::strategy::BoxedStrategy<Body>)> {
                use proptest::strategy::Strategy;
                let mut rows = Vec::new();
                for (sub, s) in $uenum::arbitrary_rows() {
                    let s = (0u8..3, s).prop_map(|(k, r)| Body::Universal(match k {
                        0 => $umsg::Req(r),
                        1 => $umsg::Ack(r),
                        _ => $umsg::Nack(r),
                    }));
                    rows.push((format!("universal {sub}"), s.boxed()));
                }
                $(
                    for (name, s) in $imsg::arbitrary_rows() {
                        rows.push((name, s.prop_map(Body::$iface).boxed()));
                    }
                )+
                rows
            }
        }

        /// Every row of the function table, universal rows first (upstream's order).
        pub fn message_rows() -> Vec<MessageRow> {
            let mut rows = Vec::new();
            push_kind_rows(&mut rows, InterfaceCode(0), MsgType::Req, $uenum::ROWS);
            $( $imsg::push_rows(&mut rows); )+
            rows
        }
    };
}
