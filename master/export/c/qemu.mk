# check-qemu: the library and the harness cross-compiled ({{QEMU_CORE}}) and run under
# qemu-system-arm -M netduinoplus2 (an STM32F405) with semihosting over vectors.bin; with
# -icount the harness counts instructions per control cycle.
ARM_CC = arm-none-eabi-gcc
ARM_SIZE = arm-none-eabi-size
QEMU = qemu-system-arm
QEMU_ARCH = {{QEMU_ARCH}}
QEMU_CFLAGS = $(QEMU_ARCH) -O2 -ffunction-sections -fdata-sections -DHEVO_QEMU
QEMU_OBJECTS = hevo.arm.o hevo_model.arm.o check.arm.o qemu_startup.arm.o

%.arm.o: %.c hevo.h
	$(ARM_CC) $(QEMU_CFLAGS) $(HEVO_CFLAGS) -c $< -o $@

qemu_startup.arm.o: qemu_startup.c
	$(ARM_CC) $(QEMU_CFLAGS) -std=c99 -Wall -Wextra -c $< -o $@

hevo_check_qemu.elf: $(QEMU_OBJECTS) qemu.ld
	$(ARM_CC) $(QEMU_ARCH) -T qemu.ld -nostartfiles --specs=rdimon.specs -Wl,--gc-sections \
		-o $@ $(QEMU_OBJECTS)

check-qemu: hevo_check_qemu.elf vectors.bin
	@echo "the library ({{QEMU_CORE}}, -O2), bytes:"
	$(ARM_SIZE) hevo.arm.o hevo_model.arm.o
	$(QEMU) -M netduinoplus2 -nographic -monitor none -serial none \
		-semihosting-config enable=on,target=native -icount shift=0 \
		-kernel hevo_check_qemu.elf > qemu.log; status=$$?; cat qemu.log; \
		test $$status -eq 0 && grep -q '^check passed' qemu.log
