"""Pixel arrays of real event sensors, by name: (height, width) in pixels, for `--sensor-size NAME`.

Sources (the size each paper or datasheet states, width x height):

- dvs128: Lichtsteiner P, Posch C, Delbruck T (2008). A 128x128 120 dB 15 us latency asynchronous temporal contrast
  vision sensor. IEEE Journal of Solid-State Circuits 43(2):566-576. doi:10.1109/JSSC.2007.914337
- davis240: Brandli C, Berner R, Yang M, Liu S-C, Delbruck T (2014). A 240x180 130 dB 3 us latency global shutter
  spatiotemporal vision sensor. IEEE Journal of Solid-State Circuits 49(10):2333-2341. doi:10.1109/JSSC.2014.2342715
- davis346: iniVation DAVIS346 datasheet (346x260 pixels); Taverni G et al. (2018). Front and back illuminated
  dynamic and active pixel vision sensors comparison. IEEE Transactions on Circuits and Systems II 65(5):677-681.
- atis: Posch C, Matolin D, Wohlgenannt R (2011). A QVGA 143 dB dynamic range frame-free PWM image sensor with
  lossless pixel-level video compression and time-domain CDS. IEEE Journal of Solid-State Circuits 46(1):259-275
  (304x240 pixels).
- dvxplorer_lite: iniVation DVXplorer Lite datasheet (320x240 pixels).
- dvxplorer: Son B et al. (2017). A 640x480 dynamic vision sensor with a 9 um pixel and 300 Meps address-event
  representation. IEEE International Solid-State Circuits Conference (ISSCC), 66-67 (the Samsung sensor of the
  iniVation DVXplorer, 640x480).
- prophesee_gen3: Prophesee Gen3 VGA CD sensor (PPS3MVCD; 640x480 pixels), Prophesee EVK datasheets.
- prophesee_gen4: Finateu T et al. (2020). A 1280x720 back-illuminated stacked temporal contrast event-based vision
  sensor with 4.86 um pixels, 1.066 GEPS readout, programmable event-rate controller and compressive data-formatting
  pipeline. IEEE International Solid-State Circuits Conference (ISSCC), 112-114 (Sony IMX636 / Prophesee Gen4.1).
- samsung_gen4: Suh Y et al. (2020). A 1280x960 dynamic vision sensor with a 4.95 um pixel pitch and motion
  artifact minimization. IEEE International Symposium on Circuits and Systems (ISCAS).
"""

from __future__ import annotations

#: sensor name -> (height, width) in pixels
SENSOR_SIZES: dict[str, tuple[int, int]] = {
    "dvs128": (128, 128),
    "davis240": (180, 240),
    "davis346": (260, 346),
    "atis": (240, 304),
    "dvxplorer_lite": (240, 320),
    "dvxplorer": (480, 640),
    "prophesee_gen3": (480, 640),
    "prophesee_gen4": (720, 1280),
    "imx636": (720, 1280),
    "samsung_gen4": (960, 1280),
}
