//! The Player 3.0.2 device server: TCP sessions, the device table and the stage driver.
