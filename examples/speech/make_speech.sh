#!/bin/sh
# Re-create the bundled example speech (our own synthetic speech; needs Debian espeak-ng and sox).
# Output: 16 kHz mono 16-bit wav with 0.4 s of silence at both ends.
set -e
cd "$(dirname "$0")"
say() {  # say VOICE SPEED OUT TEXT
  espeak-ng -v "$1" -s "$2" -w /tmp/_hm_say.wav "$4"
  sox /tmp/_hm_say.wav -r 16000 -c 1 -b 16 "$3" pad 0.4 0.4 gain -n -3
  rm -f /tmp/_hm_say.wav
}
say en-us 150 speech_male.wav "When we talk, our heads keep moving. We nod to stress a word, tilt to one side when we ask a question, and turn away while we look for the next idea."
say en+f3 155 speech_female.wav "Motion capture records every small rotation of the head. From many minutes of such recordings, a model can learn how speech and movement go together."
say en-us 160 short.wav "Hello, how are you today?"
