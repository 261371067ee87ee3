//! The Bluefin codec against the fact sheet: its example lines keep their checksums and read
//! as documented, malformed input is a typed error naming its field, times, positions and
//! numbers round-trip as the Huxley writes them, and payload sentences know their ack id.

use super::*;

/// Lines from the fact sheet's constructed transcript (checksums as printed there).
#[test]
fn fact_sheet_lines_keep_their_checksums() {
    for line in [
        "$BPLOG,ACK,ON*1E",
        "$BPLOG,NVG,ON*08",
        "$BPSTS,120000.000,1,Deploy*6D",
        "$BPRMB,120004.000,180,10,0,1.5,1,0*59",
        "$BPTRM,120011.000*68",
        "$BPBOY,120012.000*74",
        "$BPSIL,120013.000,1*6A",
        "$BPRCE,120014.000,0*6E",
        "$BPABT,120015.000,backseat abort,1*03",
        "$BPSMC,120016.000,1*64",
        "$BPCTD,120017.000,4.2,12.5,201.325,120016.900*7C",
        "$BPDCL,120018.000,CgQIARAC*60",
        "$BPTMR,120019.000,3,$CARXD:1:0:0:1:1/51*1B",
        "$BPRMB,120030.000,0,0,2,0,0,1*7E",
    ] {
        let s = Sentence::parse(line).unwrap_or_else(|e| panic!("{line}: {e}"));
        assert_eq!(s.format(), line, "sentence round trip");
        let typed = FromPayload::from_sentence(&s).unwrap_or_else(|e| panic!("{line}: {e}"));
        assert!(!matches!(typed, FromPayload::Other(_)), "{line}");
        assert_eq!(typed.to_sentence().format(), line, "typed round trip");
    }
    for line in [
        "$BFACK,120000.120,LOG,120000.000,,2,0,*24",
        "$BFNVG,120002.000,4221.5040,N,07105.2560,W,1,25.3,0.0,90.0,0.5,-1.2,120001.950*42",
        "$BFNVR,120002.010,1.50,0.00,0.00,0.10,0.00,0.20*7B",
        "$BFMIS,120003.000,demo.dive,Running*15",
        "$BFMSC,120003.500,backseat control enabled*48",
        "$BFACK,120029.000,RMB,120028.000,,1,0,depth too deep*31",
        "$BFMIS,120020.000,demo.dive,Stopped*1A",
        "$BFCTL,120021.000,1*70",
        "$BFCTL,120022.000,0*72",
        "$BFBOY,120023.000,2,0,done,-1.5*65",
        "$BFTRM,120024.000,2,0,done,1.2,0.3*56",
        "$BFRVL,120025.000,1200,1.5*53",
        "$BFDVL,120026.000,1.5,0.01,-0.02,10.1,10.2,10.3,10.4,12.5,120025.900*48",
        "$BFCTD,120027.000,42000,12.5,201.325,120026.900*74",
        "$BFSHT,120028.000*70",
    ] {
        let s = Sentence::parse(line).unwrap_or_else(|e| panic!("{line}: {e}"));
        assert_eq!(s.format(), line);
        let typed = FromHuxley::from_sentence(&s).unwrap_or_else(|e| panic!("{line}: {e}"));
        assert!(!matches!(typed, FromHuxley::Other(_)), "{line}");
    }
}

#[test]
fn nvg_reads_the_fact_sheet_example() {
    let s = Sentence::parse(
        "$BFNVG,120002.000,4221.5040,N,07105.2560,W,1,25.3,0.0,90.0,0.5,-1.2,120001.950*42",
    )
    .unwrap();
    let FromHuxley::Nvg(n) = FromHuxley::from_sentence(&s).unwrap() else {
        panic!()
    };
    assert!((n.lat - 42.3584).abs() < 1e-9, "{}", n.lat);
    assert!((n.lon + 71.0876).abs() < 1e-9, "{}", n.lon);
    assert_eq!(n.quality, Some(1));
    assert_eq!(
        (n.altitude, n.depth, n.heading, n.roll, n.pitch),
        (Some(25.3), Some(0.0), Some(90.0), Some(0.5), Some(-1.2))
    );
    assert_eq!(n.fix_time, Some(12.0 * 3600.0 + 1.95));
    assert_eq!(n.time, 12.0 * 3600.0 + 2.0);
}

#[test]
fn checksum_is_optional_but_checked_when_present() {
    assert!(Sentence::parse("$BFSHT,120028.000").is_ok());
    assert!(Sentence::parse("  $BFSHT,120028.000*70  ").is_ok());
    assert!(Sentence::parse("$BFSHT,120028.000*70\r").is_ok());
    assert_eq!(
        Sentence::parse("$BFSHT,120028.000*71"),
        Err(CodecError::BadChecksum {
            given: 0x71,
            computed: 0x70
        })
    );
    assert!(matches!(
        Sentence::parse("$BFSHT,120028.000*ZZ"),
        Err(CodecError::MalformedChecksum(_))
    ));
}

#[test]
fn malformed_lines_are_typed_errors() {
    type Want = fn(&CodecError) -> bool;
    let cases: &[(&str, Want)] = &[
        ("", |e| *e == CodecError::Empty),
        ("   ", |e| *e == CodecError::Empty),
        ("BFSHT,120000.000", |e| *e == CodecError::NoStart),
        ("$BFSH,1", |e| matches!(e, CodecError::BadAddress(_))),
        ("$BFSHTX,1", |e| matches!(e, CodecError::BadAddress(_))),
        ("$", |e| matches!(e, CodecError::BadAddress(_))),
        ("$BF\u{e9}HT,1", |e| *e == CodecError::NotAscii),
    ];
    for (line, want) in cases {
        let e = Sentence::parse(line).unwrap_err();
        assert!(want(&e), "{line:?}: {e:?}");
    }
    let long = format!("$BFMSC,{}", "x".repeat(MAX_SENTENCE_BYTES));
    assert!(matches!(
        Sentence::parse(&long),
        Err(CodecError::TooLong(_))
    ));
    // Without a checksum the bound counts the three bytes `format` adds, so what parses formats
    // to a line that parses again (the bluefin_codec fuzzer's finding, seed
    // `fuzz/corpus/regression-too-long-without-checksum`).
    let at_bound = |n: usize| format!("$BFMSC,{}", "x".repeat(n - "$BFMSC,".len()));
    assert_eq!(
        Sentence::parse(&at_bound(MAX_SENTENCE_BYTES - 2)),
        Err(CodecError::TooLong(MAX_SENTENCE_BYTES + 1))
    );
    let fits = Sentence::parse(&at_bound(MAX_SENTENCE_BYTES - 3)).unwrap();
    assert_eq!(fits.format().len(), MAX_SENTENCE_BYTES);
    assert_eq!(Sentence::parse(&fits.format()), Ok(fits));
    let wide = format!("$BFMSC{}", ",".repeat(MAX_FIELDS + 1));
    assert_eq!(Sentence::parse(&wide), Err(CodecError::TooManyFields));
}

#[test]
fn typed_errors_name_the_field() {
    for (line, index) in [
        ("$BFNVG,120002.000,42x1.5040,N,07105.2560,W,1,,,,,,", 2),
        ("$BFNVG,120002.000,4221.5040,N,07105.2560,Q,1,,,,,,", 4),
        ("$BFNVG,120002.000,4221.5040,N,07105.2560,W,1,nan,,,,,", 7),
        ("$BFNVG,1200,4221.5040,N,07105.2560,W,1,,,,,,", 1),
        ("$BFACK,120000.000,RMB,,,7,0,", 5),
        ("$BFNVR,120000.000,inf", 2),
        ("$BPRMB,120004.000,180,10,9,1.5,1,0", 4),
        ("$BPLOG,NVGX,ON", 1),
    ] {
        let s = Sentence::parse(line).unwrap();
        let e = if s.talker == "BF" {
            FromHuxley::from_sentence(&s).unwrap_err()
        } else {
            FromPayload::from_sentence(&s).unwrap_err()
        };
        match e {
            CodecError::Invalid { index: i, .. } | CodecError::Missing { index: i, .. } => {
                assert_eq!(i, index, "{line}: {e}")
            }
            other => panic!("{line}: {other:?}"),
        }
    }
}

#[test]
fn time_of_day_round_trips_with_three_decimals() {
    for (secs, text) in [
        (0.0, "000000.000"),
        (43_200.0, "120000.000"),
        (43_201.95, "120001.950"),
        (86_399.999_4, "235959.999"),
        (86_399.999_6, "000000.000"),
    ] {
        assert_eq!(format_time(secs), text);
    }
    assert_eq!(parse_time("120001.950"), Some(43_201.95));
    assert_eq!(parse_time("120001"), Some(43_201.0));
    for bad in ["", "12000", "250000.0", "126000.0", "12a000.0", "120000.-1"] {
        assert_eq!(parse_time(bad), None, "{bad}");
    }
}

#[test]
fn nvg_time_of_day_takes_the_nearest_date() {
    let day = 20_000.0 * 86_400.0;
    assert_eq!(
        unix_of_time_of_day(43_200.0, day + 43_201.0),
        day + 43_200.0
    );
    // Read just after midnight, stamped just before: yesterday.
    assert_eq!(unix_of_time_of_day(86_399.9, day + 0.1), day - 0.1);
    // Read just before midnight, stamped just after: tomorrow.
    assert_eq!(
        unix_of_time_of_day(0.1, day + 86_399.9),
        day + 86_400.0 + 0.1
    );
}

#[test]
fn lat_lon_format_and_parse_agree() {
    assert_eq!(format_lat_lon(42.3584, true), ("4221.5040".into(), 'N'));
    assert_eq!(format_lat_lon(-71.0876, false), ("07105.2560".into(), 'W'));
    assert_eq!(format_lat_lon(-0.5, true), ("0030.0000".into(), 'S'));
    assert_eq!(
        format_lat_lon(5.99999999, false),
        ("00600.0000".into(), 'E')
    );
    // Unpadded longitude (Goby3 would read 710 degrees 5.256 minutes).
    let lon = parse_lat_lon("7105.256", "W", false).unwrap();
    assert!((lon + 71.0876).abs() < 1e-9);
    assert_eq!(parse_lat_lon("4260.0000", "N", true), None);
    assert_eq!(parse_lat_lon("9100.0000", "N", true), None);
    assert_eq!(parse_lat_lon("4221.5", "X", true), None);
    assert_eq!(parse_lat_lon("21", "N", true), None);
    for deg in [0.0f64, 12.345678, -33.999999, 89.9, -179.5, 179.99999] {
        for is_lat in [true, false] {
            if is_lat && deg.abs() > 90.0 {
                continue;
            }
            let (t, h) = format_lat_lon(deg, is_lat);
            let back = parse_lat_lon(&t, &h.to_string(), is_lat).unwrap();
            // 4 decimals of a minute: 0.0001/60 degree ≈ 0.2 m.
            assert!((back - deg).abs() < 1e-6, "{deg} → {t}{h} → {back}");
        }
    }
}

#[test]
fn ack_text_keeps_its_commas() {
    let s = Sentence::parse("$BFACK,120029.000,rmb,120028.000,,1,0,too deep, and slow").unwrap();
    let FromHuxley::Ack(a) = FromHuxley::from_sentence(&s).unwrap() else {
        panic!()
    };
    assert_eq!(a.command, "RMB");
    assert_eq!(a.status, AckStatus::Failed);
    assert_eq!(a.text, "too deep, and slow");
}

#[test]
fn payload_sentences_know_their_ack_id_and_time() {
    let rmb = FromPayload::Rmb(Rmb::stop(43_230.0));
    assert_eq!(rmb.id(), "RMB");
    assert_eq!(rmb.time_text(), "120030.000");
    let log = FromPayload::Log {
        id: "nvg".into(),
        on: true,
    };
    assert_eq!(log.id(), "LOG");
    assert_eq!(log.time_text(), "");
    assert_eq!(log.to_sentence().format(), "$BPLOG,NVG,ON*08");
}

#[test]
fn tmr_escape_keeps_the_sentence_one_line() {
    assert_eq!(tmr_escape("$CARXD,1*51\r\n"), "$CARXD:1/51  ");
}

#[test]
fn ctd_numbers_have_ten_significant_digits() {
    assert_eq!(sig10(201.325), "201.325");
    assert_eq!(sig10(4.2), "4.2");
    assert_eq!(sig10(1.0 / 3.0), "0.3333333333");
    assert_eq!(sig10(123456.789012), "123456.789");
}
