//! "Never allocate more than the bytes actually received": the decoder and framer are run under a
//! counting allocator with hostile counts and sizes, and their peak memory is measured.
//!
//! One test function only, so no other test thread allocates while a measurement runs.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use player_proto::{
    DecodeLimits, DeviceAddr, Error, Framer, InterfaceCode, Message, MsgHeader, MsgType, Problem,
    decode_body,
};

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let now = LIVE.fetch_add(layout.size(), Ordering::SeqCst) + layout.size();
            PEAK.fetch_max(now, Ordering::SeqCst);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::SeqCst);
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// Runs `f` and returns its result with the peak extra memory it used.
fn measure<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let base = LIVE.load(Ordering::SeqCst);
    PEAK.store(base, Ordering::SeqCst);
    let out = f();
    (out, PEAK.load(Ordering::SeqCst) - base)
}

fn header(interf: InterfaceCode, t: MsgType, subtype: u8, size: usize) -> MsgHeader {
    MsgHeader {
        size: size as u32,
        ..MsgHeader::new(DeviceAddr::new(0, 6665, interf, 0), t, subtype, 0.0)
    }
}

fn words(ws: &[u32]) -> Vec<u8> {
    ws.iter().flat_map(|w| w.to_be_bytes()).collect()
}

#[test]
fn hostile_counts_and_sizes_cost_nothing() {
    let limits = DecodeLimits::default();

    // 2^28 doubles announced, 8 bytes sent.
    let body = words(&[0x1000_0000, 0x1000_0000, 0, 0]);
    let h = header(InterfaceCode::RANGER, MsgType::Data, 1, body.len());
    let (r, peak) = measure(|| decode_body(&h, &body, &limits));
    assert!(matches!(
        r,
        Err(Error::Malformed {
            problem: Problem::CountBeyondBody { .. },
            ..
        })
    ));
    assert!(peak < 1024, "peak {peak}");

    // A count hidden in a nested struct: ranger RANGESTAMPED's geometry element poses.
    let mut body = words(&[0, 0]); // data: no ranges
    body.extend(words(&[1])); // have_geom
    body.extend(vec![0u8; 72]); // pose + size
    body.extend(words(&[u32::MAX, u32::MAX])); // element_poses: 4 billion poses
    let h = header(InterfaceCode::RANGER, MsgType::Data, 2, body.len());
    let (r, peak) = measure(|| decode_body(&h, &body, &limits));
    let err = r.unwrap_err();
    assert!(
        err.to_string().starts_with(
            "malformed player_ranger_data_rangestamped_t.geom.element_poses: count 4294967295"
        ),
        "{err}"
    );
    assert!(peak < 1024, "peak {peak}");

    // Above a fixed C capacity: 4097 devices in a DEVLIST reply.
    let mut body = words(&[4097, 4097]);
    body.extend(vec![0u8; 4097 * 16]);
    let h = header(InterfaceCode::PLAYER, MsgType::RespAck, 1, body.len());
    let (r, peak) = measure(|| decode_body(&h, &body, &limits));
    assert!(matches!(
        r,
        Err(Error::Malformed {
            problem: Problem::CountAboveMax {
                count: 4097,
                max: 4096
            },
            ..
        })
    ));
    assert!(peak < 1024, "peak {peak}");

    // A valid 640x480 RGB image: the decoded image is the only sizeable allocation.
    let image = player_proto::CameraDataState {
        width: 640,
        height: 480,
        bpp: 24,
        format: 5,
        fdiv: 1,
        compression: 0,
        image: vec![7; 640 * 480 * 3],
    };
    let msg = Message::new(
        DeviceAddr::new(0, 6665, InterfaceCode::CAMERA, 0),
        0.0,
        player_proto::CameraData::State(image),
    );
    let bytes = msg.encode().unwrap();
    let h = MsgHeader::from_bytes(bytes[..40].try_into().unwrap()).unwrap();
    let (r, peak) = measure(|| decode_body(&h, &bytes[40..], &limits).map(drop));
    r.unwrap();
    assert!(
        peak <= bytes.len() + 1024,
        "peak {peak} for {} bytes",
        bytes.len()
    );

    // The framer: a header announcing 30 MiB buffers only what arrived ...
    let mut stream = header(InterfaceCode::CAMERA, MsgType::Data, 1, 30 << 20)
        .to_bytes()
        .to_vec();
    stream.extend(vec![0u8; 1000]);
    let (r, peak) = measure(|| {
        let mut framer = Framer::new(limits);
        framer.push(&stream);
        framer.next_frame().map(|f| f.is_none())
    });
    assert_eq!(r, Ok(true));
    assert!(peak < 4 * stream.len(), "peak {peak}");

    // ... and one announcing more than the cap is refused at once.
    let (r, peak) = measure(|| {
        let mut framer = Framer::new(DecodeLimits { max_body: 1 << 20 });
        framer.push(&stream);
        framer.next_frame().map(|f| f.is_none())
    });
    assert!(matches!(r, Err(Error::BodyTooLarge { .. })));
    assert!(peak < 4 * stream.len(), "peak {peak}");
    println!("hostile counts and sizes: errors without allocating beyond the received bytes");
}
