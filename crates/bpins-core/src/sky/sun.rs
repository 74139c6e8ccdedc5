//! Sun position from the frame or from UTC time and place (NREL SPA). (Being written.)
