// SPDX-License-Identifier: Apache-2.0
// The size baseline (bench/board_size): a sketch that only opens Serial. What another sketch
// costs beyond it is its own code, not the core's or the serial port's buffers.
void setup() { Serial.begin(115200); }

void loop() {}
