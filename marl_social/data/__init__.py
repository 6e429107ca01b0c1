"""Learning data: demonstration and decision files (formats, validation), INTERACTION loader."""
