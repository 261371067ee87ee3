//! Serial ports for the byte links: the settings a driver's config gives (device path, baud,
//! data bits, parity, stop bits, flow control) and opening them as an async stream with
//! `tokio-serial`. Works the same on a USB adapter and on a pseudo-terminal.

use tokio_serial::{DataBits, FlowControl, Parity, SerialPortBuilderExt, SerialStream, StopBits};

/// Parity as written in the config.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SerialParity {
    None,
    Odd,
    Even,
}

/// Flow control as written in the config.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SerialFlowControl {
    None,
    Software,
    Hardware,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SerialSettings {
    pub path: String,
    pub baud: u32,
    /// 5 to 8.
    pub data_bits: u8,
    pub parity: SerialParity,
    /// 1 or 2.
    pub stop_bits: u8,
    pub flow_control: SerialFlowControl,
}

impl SerialSettings {
    /// 8N1, no flow control: what both Iver3 and the SV2 use.
    pub fn new_8n1(path: impl Into<String>, baud: u32) -> Self {
        Self {
            path: path.into(),
            baud,
            data_bits: 8,
            parity: SerialParity::None,
            stop_bits: 1,
            flow_control: SerialFlowControl::None,
        }
    }

    /// What the operator should do about a port that would not open, when we know: on a fresh
    /// machine the usual failure is permission, since serial devices belong to the `dialout`
    /// group (Debian, Ubuntu) and a user is not in it until added.
    pub fn open_hint(&self, err: &std::io::Error) -> Option<String> {
        let denied = err.kind() == std::io::ErrorKind::PermissionDenied
            || err.to_string().contains("Permission denied");
        denied.then(|| {
            format!(
                "cannot open serial port {}: permission denied. Serial ports belong to the \
                 `dialout` group: add the user that runs frontseat to it \
                 (`sudo usermod -aG dialout $USER`, then log in again; the packaged `frontseat` \
                 service user already is), or check the device's owner and mode with `ls -lL {}`",
                self.path, self.path
            )
        })
    }

    /// Opens the port; needs a tokio runtime.
    pub fn open(&self) -> std::io::Result<SerialStream> {
        let data_bits = match self.data_bits {
            5 => DataBits::Five,
            6 => DataBits::Six,
            7 => DataBits::Seven,
            _ => DataBits::Eight,
        };
        let stop_bits = if self.stop_bits == 2 {
            StopBits::Two
        } else {
            StopBits::One
        };
        let parity = match self.parity {
            SerialParity::None => Parity::None,
            SerialParity::Odd => Parity::Odd,
            SerialParity::Even => Parity::Even,
        };
        let flow = match self.flow_control {
            SerialFlowControl::None => FlowControl::None,
            SerialFlowControl::Software => FlowControl::Software,
            SerialFlowControl::Hardware => FlowControl::Hardware,
        };
        tokio_serial::new(&self.path, self.baud)
            .data_bits(data_bits)
            .stop_bits(stop_bits)
            .parity(parity)
            .flow_control(flow)
            .open_native_async()
            .map_err(std::io::Error::from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_port_without_permission_names_the_dialout_group() {
        let s = SerialSettings::new_8n1("/dev/ttyUSB0", 19200);
        // As tokio-serial reports EACCES from open(2).
        let denied = std::io::Error::new(std::io::ErrorKind::PermissionDenied, "Permission denied");
        let hint = s.open_hint(&denied).expect("a hint for a permission error");
        assert!(hint.contains("/dev/ttyUSB0"), "{hint}");
        assert!(hint.contains("`dialout` group"), "{hint}");
        assert!(hint.contains("usermod -aG dialout"), "{hint}");
        // serialport may carry the errno's text with another kind.
        let other_kind = std::io::Error::other("Permission denied");
        assert!(s.open_hint(&other_kind).is_some());
        // Not every failure is the operator's to fix by group: a missing device is retried quietly.
        let missing =
            std::io::Error::new(std::io::ErrorKind::NotFound, "No such file or directory");
        assert_eq!(s.open_hint(&missing), None);
    }
}
